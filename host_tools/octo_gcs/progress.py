"""Progress output: one updating line on a terminal, plain lines otherwise."""

import sys
import time


class Progress:
    """``update(text)`` redraws one line (\\r) on a TTY; elsewhere it prints a plain
    line when the text's `key` changes or every `every` seconds. ``say(text)``
    prints a permanent line; ``done()`` ends the updating line."""

    def __init__(self, stream=None, every=2.0, tty=None):
        self.stream = stream if stream is not None else sys.stdout
        self.tty = self.stream.isatty() if tty is None else tty
        self.every = every
        self._width = 0
        self._last_key = None
        self._last_t = 0.0

    def update(self, text, key=None):
        if self.tty:
            pad = max(0, self._width - len(text))
            self.stream.write("\r" + text + " " * pad)
            self._width = len(text)
            self.stream.flush()
            return
        now = time.monotonic()
        if key != self._last_key or now - self._last_t >= self.every:
            self._last_key, self._last_t = key, now
            self.stream.write(text + "\n")
            self.stream.flush()

    def say(self, text):
        self.done()
        self.stream.write(text + "\n")
        self.stream.flush()

    def done(self):
        if self.tty and self._width:
            self.stream.write("\r" + " " * self._width + "\r")
            self.stream.flush()
        self._width = 0


class Quiet(Progress):
    def __init__(self):
        super().__init__(stream=sys.stdout, tty=False)

    def update(self, text, key=None):
        pass

    def say(self, text):
        pass

// json: recursive-descent reader, RFC 8259 grammar (plus NaN/Infinity), depth-limited.
#include "json.hpp"

#include <cmath>
#include <cstdlib>

namespace json
{

const char *Value::kind_name() const
{
	switch (kind) {
	case Kind::Null: return "null";
	case Kind::Bool: return "a boolean";
	case Kind::Number: return "a number";
	case Kind::String: return "a string";
	case Kind::Array: return "an array";
	case Kind::Object: return "an object";
	}
	return "?";
}

namespace
{

class Parser
{
      public:
	explicit Parser(const std::string &t) : s_(t) {}

	Value document()
	{
		ws();
		Value v = value(0);
		ws();
		if (i_ != s_.size())
			fail("unexpected text after the document");
		return v;
	}

      private:
	const std::string &s_;
	size_t i_ = 0;

	[[noreturn]] void fail(const std::string &what) const
	{
		size_t line = 1, col = 1;
		for (size_t k = 0; k < i_ && k < s_.size(); k++) {
			if (s_[k] == '\n') {
				line++;
				col = 1;
			} else {
				col++;
			}
		}
		throw ParseError("line " + std::to_string(line) + ", column " + std::to_string(col) + ": " + what);
	}

	void ws()
	{
		while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r'))
			i_++;
	}

	bool lit(const char *w)
	{
		size_t n = 0;
		while (w[n])
			n++;
		if (s_.compare(i_, n, w) == 0) {
			i_ += n;
			return true;
		}
		return false;
	}

	Value value(int depth)
	{
		if (depth > 64)
			fail("nesting too deep");
		if (i_ >= s_.size())
			fail("unexpected end of input");
		Value v;
		char c = s_[i_];
		if (c == '{') {
			v.kind = Value::Kind::Object;
			i_++;
			ws();
			if (i_ < s_.size() && s_[i_] == '}') {
				i_++;
				return v;
			}
			for (;;) {
				ws();
				if (i_ >= s_.size() || s_[i_] != '"')
					fail("expected a key string");
				std::string k = string();
				ws();
				if (i_ >= s_.size() || s_[i_] != ':')
					fail("expected ':'");
				i_++;
				ws();
				for (const auto &kv : v.obj)
					if (kv.first == k)
						fail("duplicate key '" + k + "'");
				v.obj.emplace_back(k, value(depth + 1));
				ws();
				if (i_ < s_.size() && s_[i_] == ',') {
					i_++;
					continue;
				}
				if (i_ < s_.size() && s_[i_] == '}') {
					i_++;
					return v;
				}
				fail("expected ',' or '}'");
			}
		}
		if (c == '[') {
			v.kind = Value::Kind::Array;
			i_++;
			ws();
			if (i_ < s_.size() && s_[i_] == ']') {
				i_++;
				return v;
			}
			for (;;) {
				ws();
				v.arr.push_back(value(depth + 1));
				ws();
				if (i_ < s_.size() && s_[i_] == ',') {
					i_++;
					continue;
				}
				if (i_ < s_.size() && s_[i_] == ']') {
					i_++;
					return v;
				}
				fail("expected ',' or ']'");
			}
		}
		if (c == '"') {
			v.kind = Value::Kind::String;
			v.str = string();
			return v;
		}
		if (lit("true")) {
			v.kind = Value::Kind::Bool;
			v.b = true;
			return v;
		}
		if (lit("false")) {
			v.kind = Value::Kind::Bool;
			return v;
		}
		if (lit("null"))
			return v;
		// Not JSON, but what Python's json.dumps writes for non-finite floats:
		// read them so that the vehicle loader can name the offending key.
		v.kind = Value::Kind::Number;
		if (lit("NaN")) {
			v.num = std::nan("");
			return v;
		}
		if (lit("Infinity")) {
			v.num = HUGE_VAL;
			return v;
		}
		if (lit("-Infinity")) {
			v.num = -HUGE_VAL;
			return v;
		}
		if (c == '-' || (c >= '0' && c <= '9')) {
			v.kind = Value::Kind::Number;
			v.num = number();
			return v;
		}
		fail(std::string("unexpected character '") + c + "'");
	}

	double number()
	{
		size_t st = i_;
		auto digits = [&]() {
			size_t d = i_;
			while (i_ < s_.size() && s_[i_] >= '0' && s_[i_] <= '9')
				i_++;
			return i_ > d;
		};
		if (s_[i_] == '-')
			i_++;
		if (i_ < s_.size() && s_[i_] == '0')
			i_++;
		else if (!digits())
			fail("bad number");
		if (i_ < s_.size() && s_[i_] == '.') {
			i_++;
			if (!digits())
				fail("bad number");
		}
		if (i_ < s_.size() && (s_[i_] == 'e' || s_[i_] == 'E')) {
			i_++;
			if (i_ < s_.size() && (s_[i_] == '+' || s_[i_] == '-'))
				i_++;
			if (!digits())
				fail("bad number");
		}
		std::string tok = s_.substr(st, i_ - st);
		double d = std::strtod(tok.c_str(), nullptr);
		if (!std::isfinite(d))
			fail("number out of range");
		return d;
	}

	static void utf8(std::string &o, unsigned cp)
	{
		if (cp < 0x80) {
			o += static_cast<char>(cp);
		} else if (cp < 0x800) {
			o += static_cast<char>(0xC0 | (cp >> 6));
			o += static_cast<char>(0x80 | (cp & 0x3F));
		} else if (cp < 0x10000) {
			o += static_cast<char>(0xE0 | (cp >> 12));
			o += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
			o += static_cast<char>(0x80 | (cp & 0x3F));
		} else {
			o += static_cast<char>(0xF0 | (cp >> 18));
			o += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
			o += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
			o += static_cast<char>(0x80 | (cp & 0x3F));
		}
	}

	unsigned hex4()
	{
		if (i_ + 4 > s_.size())
			fail("bad \\u escape");
		unsigned v = 0;
		for (int k = 0; k < 4; k++) {
			char h = s_[i_++];
			v <<= 4;
			if (h >= '0' && h <= '9')
				v |= static_cast<unsigned>(h - '0');
			else if (h >= 'a' && h <= 'f')
				v |= static_cast<unsigned>(h - 'a' + 10);
			else if (h >= 'A' && h <= 'F')
				v |= static_cast<unsigned>(h - 'A' + 10);
			else
				fail("bad \\u escape");
		}
		return v;
	}

	std::string string()
	{
		i_++; // opening quote
		std::string o;
		for (;;) {
			if (i_ >= s_.size())
				fail("unterminated string");
			unsigned char c = static_cast<unsigned char>(s_[i_++]);
			if (c == '"')
				return o;
			if (c < 0x20)
				fail("control character in string");
			if (c != '\\') {
				o += static_cast<char>(c);
				continue;
			}
			if (i_ >= s_.size())
				fail("unterminated string");
			char e = s_[i_++];
			switch (e) {
			case '"': o += '"'; break;
			case '\\': o += '\\'; break;
			case '/': o += '/'; break;
			case 'b': o += '\b'; break;
			case 'f': o += '\f'; break;
			case 'n': o += '\n'; break;
			case 'r': o += '\r'; break;
			case 't': o += '\t'; break;
			case 'u': {
				unsigned cp = hex4();
				if (cp >= 0xD800 && cp < 0xDC00 && i_ + 1 < s_.size() && s_[i_] == '\\' &&
				    s_[i_ + 1] == 'u') {
					i_ += 2;
					unsigned lo = hex4();
					if (lo < 0xDC00 || lo > 0xDFFF)
						fail("bad surrogate pair");
					cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
				}
				utf8(o, cp);
				break;
			}
			default: fail("bad escape");
			}
		}
	}
};

} // namespace

Value parse(const std::string &text) { return Parser(text).document(); }

} // namespace json

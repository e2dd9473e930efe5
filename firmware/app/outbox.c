/* outbox.c - the app's event ring (see outbox.h). */
#include "outbox.h"

#include <string.h>

void outbox_post(struct app_outbox *o, const struct app_event *e)
{
	if (o->count >= APP_OUTBOX_LEN) {
		o->dropped++;
		return;
	}
	o->ev[(o->head + o->count) % APP_OUTBOX_LEN] = *e;
	o->count++;
}

bool outbox_pop(struct app_outbox *o, struct app_event *e)
{
	if (!o->count)
		return false;
	*e = o->ev[o->head];
	o->head = (uint8_t)((o->head + 1u) % APP_OUTBOX_LEN);
	o->count--;
	return true;
}

struct app_event *outbox_put(struct app_outbox *o)
{
	if (o->count >= APP_OUTBOX_LEN) {
		o->dropped++;
		return NULL;
	}
	struct app_event *e = &o->ev[(o->head + o->count) % APP_OUTBOX_LEN];
	o->count++;
	memset(e, 0, sizeof *e);
	return e;
}

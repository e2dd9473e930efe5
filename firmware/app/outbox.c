/* outbox.c - the app's event ring (see outbox.h). */
#include "outbox.h"

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
	e->kind = e->severity = e->cmd = e->result = e->progress = 0;
	e->param_index = 0;
	e->origin = 0;
	e->value = 0.0f;
	return e;
}

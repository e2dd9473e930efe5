/*
 * experiment.c - identification experiments (placeholder until issue 6).
 *
 * No experiment is built yet: exp_available() is false for every id and
 * exp_start() answers MAV_RESULT_UNSUPPORTED with a reason. Issue 6 replaces
 * this file (same contract, experiment.h).
 */
#include "experiment.h"

#include <stdio.h>
#include <string.h>

#include <common/mavlink.h>

bool exp_available(int id)
{
	(void)id;
	return false;
}

int exp_start(struct experiment *e, int id, const struct app_params *p, char *why, size_t cap)
{
	(void)p;
	memset(e, 0, sizeof *e);
	snprintf(why, cap, "Experiment %d not available in this build", id);
	return MAV_RESULT_UNSUPPORTED;
}

enum exp_state exp_step(struct experiment *e, const struct exp_input *in, struct exp_output *out)
{
	(void)in;
	(void)out;
	return e->state;
}

void exp_abort(struct experiment *e, const char *reason)
{
	if (e->state == EXP_RUNNING) {
		e->state = EXP_ABORTED;
		snprintf(e->msg, sizeof e->msg, "Experiment %d aborted: %s", e->id, reason);
		e->msg_severity = MAV_SEVERITY_WARNING;
	}
}

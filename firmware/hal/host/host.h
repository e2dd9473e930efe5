/* host.h - internals shared by the host platform's files (not seen by app/). */
#ifndef OCTO_HOST_H
#define OCTO_HOST_H

#include <stdbool.h>

void param_file_set_path(const char *path);

/* LCM log: URL as for lcm_create; file://PATH writes an event log stamped with
 * plant time (reproducible). Returns 0 or -1. */
int lcm_log_open(const char *url);
void lcm_log_close(void);

#endif /* OCTO_HOST_H */

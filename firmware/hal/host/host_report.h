/*
 * host_report.h - the console of the host parts that both octo-fw and octo-sil link
 * (param_file.c, xp_client.c): one line "octo-fw: ..." on stderr. Defined by the
 * program that links them (host_hal.c for octo-fw, hal/sil/sil.c for octo-sil).
 */
#ifndef OCTO_HOST_REPORT_H
#define OCTO_HOST_REPORT_H

void host_report(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

#endif /* OCTO_HOST_REPORT_H */

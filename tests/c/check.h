/*
 * Tiny check helpers shared by the C conformance programs in tests/c.
 *
 * CHECK(cond, ...) records a failure with file, line and a printf message and
 * carries on, so one run reports every broken rule; check_finish() prints the
 * summary line tests/c_conformance.rs looks for and gives the exit code.
 */
#ifndef MSBSDF_TEST_CHECK_H
#define MSBSDF_TEST_CHECK_H

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "msbsdf.h"

static unsigned long check_count;
static unsigned long check_failures;

#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
static inline void check_at(int ok, const char *file, int line, const char *fmt, ...)
{
    check_count++;
    if (!ok) {
        va_list ap;
        check_failures++;
        fprintf(stdout, "FAIL %s:%d: ", file, line);
        va_start(ap, fmt);
        vfprintf(stdout, fmt, ap);
        va_end(ap);
        fputc('\n', stdout);
        fflush(stdout);
    }
}

/* CHECK(condition, printf format, args...): the message says what failed. */
#define CHECK(cond, ...) check_at((cond) ? 1 : 0, __FILE__, __LINE__, __VA_ARGS__)

/* CHECK_STATUS(call, expected): a status-returning call gives `expected`. */
#define CHECK_STATUS(got, want)                                                       \
    do {                                                                              \
        msbsdf_status check_got_ = (got);                                             \
        msbsdf_status check_want_ = (want);                                           \
        CHECK(check_got_ == check_want_, "%s returned %u (%s), expected %u (%s)",     \
              #got, (unsigned)check_got_, msbsdf_status_message(check_got_),          \
              (unsigned)check_want_, msbsdf_status_message(check_want_));             \
    } while (0)

/* Bitwise comparison of two objects of the same type. */
#define SAME_BITS(a, b) (sizeof(a) == sizeof(b) && memcmp(&(a), &(b), sizeof(a)) == 0)

/* True when every byte of the object is zero. */
static inline int all_zero_bytes(const void *p, size_t n)
{
    const unsigned char *b = (const unsigned char *)p;
    size_t i;
    for (i = 0; i < n; i++) {
        if (b[i] != 0) {
            return 0;
        }
    }
    return 1;
}

/* True when every byte equals `c`. */
static inline int all_bytes_are(const void *p, size_t n, unsigned char c)
{
    const unsigned char *b = (const unsigned char *)p;
    size_t i;
    for (i = 0; i < n; i++) {
        if (b[i] != c) {
            return 0;
        }
    }
    return 1;
}

/* Prints the summary line and returns the process exit code. */
static inline int check_finish(const char *program)
{
    if (check_failures == 0) {
        printf("%s: ALL %lu CHECKS PASSED\n", program, check_count);
        return 0;
    }
    printf("%s: %lu OF %lu CHECKS FAILED\n", program, check_failures, check_count);
    return 1;
}

#endif /* MSBSDF_TEST_CHECK_H */

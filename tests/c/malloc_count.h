/* Counters of tests/c/malloc_count.c (see there). */
#ifndef MSBSDF_TEST_MALLOC_COUNT_H
#define MSBSDF_TEST_MALLOC_COUNT_H

extern volatile int malloc_count_enabled;
extern volatile unsigned long malloc_count_allocs;
extern volatile unsigned long malloc_count_frees;

#endif

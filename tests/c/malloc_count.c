/*
 * A malloc-counting interposer, linked into the test program: the executable's
 * malloc / calloc / realloc / free / posix_memalign / aligned_alloc /
 * memalign take precedence over libc's for every shared object, including
 * libmsbsdf.so, and forward to glibc's __libc_* entry points (which never
 * call back into these, so no recursion and no dlsym bootstrap problem).
 * Counting is on only while malloc_count_enabled is non-zero.
 */
#include <errno.h>
#include <stddef.h>

#include "malloc_count.h"

extern void *__libc_malloc(size_t size);
extern void *__libc_calloc(size_t n, size_t size);
extern void *__libc_realloc(void *p, size_t size);
extern void __libc_free(void *p);
extern void *__libc_memalign(size_t align, size_t size);

volatile int malloc_count_enabled;
volatile unsigned long malloc_count_allocs;
volatile unsigned long malloc_count_frees;

static void count_alloc(void)
{
    if (malloc_count_enabled) {
        __atomic_fetch_add(&malloc_count_allocs, 1ul, __ATOMIC_RELAXED);
    }
}

void *malloc(size_t size)
{
    count_alloc();
    return __libc_malloc(size);
}

void *calloc(size_t n, size_t size)
{
    count_alloc();
    return __libc_calloc(n, size);
}

void *realloc(void *p, size_t size)
{
    count_alloc();
    return __libc_realloc(p, size);
}

void free(void *p)
{
    if (p != NULL && malloc_count_enabled) {
        __atomic_fetch_add(&malloc_count_frees, 1ul, __ATOMIC_RELAXED);
    }
    __libc_free(p);
}

void *memalign(size_t align, size_t size)
{
    count_alloc();
    return __libc_memalign(align, size);
}

void *aligned_alloc(size_t align, size_t size)
{
    count_alloc();
    return __libc_memalign(align, size);
}

int posix_memalign(void **out, size_t align, size_t size)
{
    void *p;
    count_alloc();
    if (align < sizeof(void *) || (align & (align - 1)) != 0) {
        return EINVAL;
    }
    p = __libc_memalign(align, size);
    if (p == NULL && size != 0) {
        return ENOMEM;
    }
    *out = p;
    return 0;
}

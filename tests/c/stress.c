/*
 * Concurrency stress (issue 7): THREADS pthreads make CALLS mixed eval /
 * sample / pdf calls each on shared materials of every model, NDF and facet
 * combination that msbsdf_material_create accepts (UNSUPPORTED ones are
 * skipped, so the program grows as models land). Thread t uses seed t; the
 * FNV-1a hash of every output bit (and the final generator state) must equal
 * the single-thread run of the same seed. Usage: stress CALLS (per thread).
 * tests/c_hardening.rs runs it natively and under ThreadSanitizer.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"

#define THREADS 8
#define MAX_MATERIALS 128

typedef struct job_result {
    uint64_t hash;
    msbsdf_rng end;
    unsigned long ok;
} job_result;

static const msbsdf_material *materials[MAX_MATERIALS];
static int n_materials;
static long calls_per_thread;
static job_result reference[THREADS];
static job_result results[THREADS];
static pthread_barrier_t start;

static void hash_bytes(uint64_t *h, const void *p, size_t n)
{
    const unsigned char *b = (const unsigned char *)p;
    size_t i;
    for (i = 0; i < n; i++) {
        *h ^= b[i];
        *h *= 0x100000001b3ULL;
    }
}

static msbsdf_vec3 random_dir(msbsdf_rng *r)
{
    float z = 2.0f * msbsdf_rng_next_float(r) - 1.0f;
    float phi = 6.2831853f * msbsdf_rng_next_float(r);
    float s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    msbsdf_vec3 v;
    v.x = s * cosf(phi);
    v.y = s * sinf(phi);
    v.z = z;
    return v;
}

/* calls_per_thread calls: material and directions from the job's own
   generator; the call kind cycles sample, eval, pdf. */
static void run_job(int seed, job_result *out)
{
    msbsdf_rng r;
    uint64_t h = 0xcbf29ce484222325ULL;
    unsigned long ok = 0;
    long i;
    msbsdf_vec3 last_wo = {0.0f, 0.0f, 1.0f};
    msbsdf_rng_seed(&r, (uint64_t)seed, 0x57e55u);
    for (i = 0; i < calls_per_thread; i++) {
        const msbsdf_material *m =
            materials[(unsigned)(msbsdf_rng_next_float(&r) * (float)n_materials) % (unsigned)n_materials];
        msbsdf_vec3 wi = random_dir(&r);
        switch (i % 3) {
        case 0: {
            msbsdf_sample_result s;
            ok += msbsdf_sample(m, wi, &r, &s) == MSBSDF_STATUS_OK;
            hash_bytes(&h, &s, sizeof s);
            if (s.flags != MSBSDF_SAMPLE_ABSORBED) {
                last_wo = s.wo;
            }
            break;
        }
        case 1: {
            msbsdf_rgb f;
            ok += msbsdf_eval(m, wi, random_dir(&r), &r, &f) == MSBSDF_STATUS_OK;
            hash_bytes(&h, &f, sizeof f);
            break;
        }
        default: {
            float p;
            ok += msbsdf_pdf(m, wi, last_wo, &p) == MSBSDF_STATUS_OK;
            hash_bytes(&h, &p, sizeof p);
            break;
        }
        }
    }
    out->hash = h;
    out->end = r;
    out->ok = ok;
}

static void *worker(void *arg)
{
    int t = (int)(intptr_t)arg;
    pthread_barrier_wait(&start);
    run_job(t, &results[t]);
    return NULL;
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv)
{
    static const uint32_t ndfs[2] = {MSBSDF_NDF_BECKMANN, MSBSDF_NDF_GGX};
    static msbsdf_material *owned[MAX_MATERIALS];
    uint32_t model, facet;
    int n, t;
    double t0, t1, t2;

    calls_per_thread = argc > 1 ? atol(argv[1]) : 1000000L;
    if (calls_per_thread <= 0) {
        fprintf(stderr, "usage: stress CALLS_PER_THREAD\n");
        return 2;
    }
    /* Every model constant (0..MSBSDF_MODEL_TABULATED) x facet x NDF, one
       roughness each; skip what create refuses. */
    for (model = 0; model <= MSBSDF_MODEL_TABULATED; model++) {
        for (facet = MSBSDF_FACET_CONDUCTOR; facet <= MSBSDF_FACET_DIFFUSE; facet++) {
            for (n = 0; n < 2; n++) {
                msbsdf_material_desc d = msbsdf_material_desc_default();
                msbsdf_material *m = NULL;
                d.model = model;
                d.facet = facet;
                d.ndf = ndfs[n];
                d.alpha_x = n ? 0.6f : 0.3f;
                d.alpha_y = n ? 0.3f : 0.3f;
                /* AUTO at a tight tolerance averages thousands of walks per
                   query; a loose tolerance keeps the stress run short. */
                d.tolerance = 0.2f;
                d.eta.r = 0.143f, d.eta.g = 0.374f, d.eta.b = 1.442f;
                d.k.r = 3.983f, d.k.g = 2.385f, d.k.b = 1.603f;
                if (facet == MSBSDF_FACET_DIELECTRIC) {
                    d.eta.r = d.eta.g = d.eta.b = 1.5f;
                }
                if (msbsdf_material_create(&d, &m) == MSBSDF_STATUS_OK &&
                    n_materials < MAX_MATERIALS) {
                    owned[n_materials] = m;
                    materials[n_materials++] = m;
                }
            }
        }
    }
    CHECK(n_materials > 0, "no material could be created");
    if (n_materials == 0) {
        return check_finish("stress");
    }

    t0 = now();
    for (t = 0; t < THREADS; t++) {
        run_job(t, &reference[t]);
        CHECK(reference[t].ok == (unsigned long)calls_per_thread, "seed %d: %lu of %ld calls OK",
              t, reference[t].ok, calls_per_thread);
    }
    t1 = now();
    {
        pthread_t threads[THREADS];
        CHECK(pthread_barrier_init(&start, NULL, THREADS) == 0, "pthread_barrier_init failed");
        for (t = 0; t < THREADS; t++) {
            CHECK(pthread_create(&threads[t], NULL, worker, (void *)(intptr_t)t) == 0,
                  "pthread_create %d failed", t);
        }
        for (t = 0; t < THREADS; t++) {
            pthread_join(threads[t], NULL);
        }
        pthread_barrier_destroy(&start);
    }
    t2 = now();
    for (t = 0; t < THREADS; t++) {
        const job_result *a = &results[t], *b = &reference[t];
        CHECK(a->hash == b->hash && a->ok == b->ok && SAME_BITS(a->end, b->end),
              "seed %d: threaded hash %016llx vs single-thread %016llx", t,
              (unsigned long long)a->hash, (unsigned long long)b->hash);
    }
    printf("stress: %d materials, %d threads x %ld calls: single-thread %.2f s, threaded %.2f s "
           "(%.0f ns per call single-thread)\n",
           n_materials, THREADS, calls_per_thread, t1 - t0, t2 - t1,
           1e9 * (t1 - t0) / ((double)THREADS * (double)calls_per_thread));
    for (t = 0; t < n_materials; t++) {
        msbsdf_material_destroy(owned[t]);
    }
    return check_finish("stress");
}

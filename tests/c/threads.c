/*
 * A material is read-only after init and shareable (DESIGN.md section 2): 4
 * pthreads querying the same two materials at once (a created conductor and a
 * dielectric initialised in static storage), each job with its own
 * msbsdf_rng, reproduce the single-thread outputs bit for bit.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "check.h"

#define THREADS 4
#define JOBS 32
#define ITERS 1500

typedef struct job_result {
    uint64_t hash;    /* FNV-1a over every output bit of the job */
    msbsdf_rng end;   /* generator state after the job */
    unsigned long ok; /* calls that returned MSBSDF_STATUS_OK */
} job_result;

static const msbsdf_material *materials[2];
static job_result reference[JOBS];
static job_result results[THREADS][JOBS];
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

static msbsdf_vec3 v3(float x, float y, float z)
{
    msbsdf_vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

/* One job: ITERS rounds of sample / eval / pdf / eval_pdf / sample_with on
   both materials. */
static void run_job(int job, job_result *out)
{
    msbsdf_rng r;
    uint64_t h = 0xcbf29ce484222325ULL;
    unsigned long ok = 0;
    int i;
    msbsdf_rng_seed(&r, 0x5eed0000u + (uint64_t)job, (uint64_t)job * 3u + 1u);
    for (i = 0; i < ITERS; i++) {
        const msbsdf_material *m = materials[i & 1];
        float z = 2.0f * msbsdf_rng_next_float(&r) - 1.0f;
        float phi = 6.2831853f * msbsdf_rng_next_float(&r);
        float s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
        msbsdf_vec3 wi = v3(s * cosf(phi), s * sinf(phi), z);
        msbsdf_vec3 wo = v3(msbsdf_rng_next_float(&r) - 0.5f, msbsdf_rng_next_float(&r) - 0.5f,
                            msbsdf_rng_next_float(&r) - 0.5f);
        msbsdf_sample_result smp;
        msbsdf_rgb f;
        float p;
        ok += msbsdf_sample(m, wi, &r, &smp) == MSBSDF_STATUS_OK;
        hash_bytes(&h, &smp, sizeof smp);
        ok += msbsdf_eval(m, wi, wo, &r, &f) == MSBSDF_STATUS_OK;
        hash_bytes(&h, &f, sizeof f);
        /* An absorbed sample has wo = 0, which pdf refuses. */
        if (smp.flags != MSBSDF_SAMPLE_ABSORBED) {
            ok += msbsdf_pdf(m, wi, smp.wo, &p) == MSBSDF_STATUS_OK;
            hash_bytes(&h, &p, sizeof p);
        } else {
            ok += msbsdf_pdf(m, wi, smp.wo, &p) == MSBSDF_STATUS_INVALID_DIRECTION;
        }
        ok += msbsdf_pdf(m, wi, wo, &p) == MSBSDF_STATUS_OK;
        hash_bytes(&h, &p, sizeof p);
        {
            /* The context calls of 0.3 (radiance transport, the job's rng). */
            msbsdf_context ctx;
            msbsdf_sample_record rec;
            msbsdf_context_init(&ctx);
            ctx.rng = &r;
            msbsdf_sample_record_init(&rec);
            ok += msbsdf_eval_pdf(m, &ctx, wi, wo, &f, &p) == MSBSDF_STATUS_OK;
            hash_bytes(&h, &f, sizeof f);
            hash_bytes(&h, &p, sizeof p);
            ok += msbsdf_sample_with(m, &ctx, wi, msbsdf_rng_next_float(&r), msbsdf_rng_next_float(&r),
                                     msbsdf_rng_next_float(&r), &rec) == MSBSDF_STATUS_OK;
            hash_bytes(&h, &rec, sizeof rec);
        }
    }
    out->hash = h;
    out->end = r;
    out->ok = ok;
}

/* Thread t runs every job, starting at job t * JOBS / THREADS, so each job
   runs on all threads at once at different times. */
static void *worker(void *arg)
{
    int t = (int)(intptr_t)arg, k;
    pthread_barrier_wait(&start);
    for (k = 0; k < JOBS; k++) {
        int job = (k + t * JOBS / THREADS) % JOBS;
        run_job(job, &results[t][job]);
    }
    return NULL;
}

typedef union storage {
    unsigned char bytes[4096];
    uint64_t u64;
    long double ld;
    void *p;
} storage;

int main(void)
{
    static storage glass_storage;
    msbsdf_material_desc gold = msbsdf_material_desc_default(), glass = msbsdf_material_desc_default();
    msbsdf_material *created = NULL, *inited = NULL;
    pthread_t threads[THREADS];
    int t, j, mismatches = 0;

    gold.ndf = MSBSDF_NDF_GGX;
    gold.alpha_x = 0.5f;
    gold.alpha_y = 0.25f;
    gold.eta.r = 0.143f, gold.eta.g = 0.374f, gold.eta.b = 1.442f;
    gold.k.r = 3.983f, gold.k.g = 2.385f, gold.k.b = 1.603f;
    glass.ndf = MSBSDF_NDF_BECKMANN;
    glass.facet = MSBSDF_FACET_DIELECTRIC;
    glass.alpha_x = glass.alpha_y = 0.3f;
    glass.eta.r = glass.eta.g = glass.eta.b = 1.5f;
    CHECK_STATUS(msbsdf_material_create(&gold, &created), MSBSDF_STATUS_OK);
    CHECK_STATUS(msbsdf_material_init(&glass, glass_storage.bytes, sizeof glass_storage, &inited),
                 MSBSDF_STATUS_OK);
    if (created == NULL || inited == NULL) {
        return check_finish("threads");
    }
    materials[0] = created;
    materials[1] = inited;

    for (j = 0; j < JOBS; j++) {
        run_job(j, &reference[j]);
        CHECK(reference[j].ok == 6ul * ITERS, "job %d: %lu of %d calls OK", j, reference[j].ok,
              6 * ITERS);
    }

    CHECK(pthread_barrier_init(&start, NULL, THREADS) == 0, "pthread_barrier_init failed");
    for (t = 0; t < THREADS; t++) {
        CHECK(pthread_create(&threads[t], NULL, worker, (void *)(intptr_t)t) == 0,
              "pthread_create %d failed", t);
    }
    for (t = 0; t < THREADS; t++) {
        pthread_join(threads[t], NULL);
    }
    pthread_barrier_destroy(&start);

    for (t = 0; t < THREADS; t++) {
        for (j = 0; j < JOBS; j++) {
            const job_result *a = &results[t][j], *b = &reference[j];
            int same = a->hash == b->hash && a->ok == b->ok && SAME_BITS(a->end, b->end);
            mismatches += !same;
            CHECK(same, "thread %d job %d: hash %016llx vs single-thread %016llx", t, j,
                  (unsigned long long)a->hash, (unsigned long long)b->hash);
        }
    }
    printf("threads: %d threads x %d jobs x %d rounds (%d calls each): %d mismatches\n", THREADS,
           JOBS, ITERS, 6 * ITERS, mismatches);
    msbsdf_material_destroy(created);
    msbsdf_material_destroy(inited);
    return check_finish("threads");
}

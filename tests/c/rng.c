/*
 * msbsdf_rng against the reference PCG32 (pcg32_srandom_r / pcg32_random_r of
 * O'Neill's minimal C implementation, written here from its published
 * definition): same state after seeding, the published outputs for seed 42,
 * stream 54, and msbsdf_rng_next_float == (pcg32 >> 8) * 2^-24 bit for bit.
 */
#include <stdint.h>
#include <stdio.h>

#include "check.h"

typedef struct pcg32_random_t {
    uint64_t state;
    uint64_t inc;
} pcg32_random_t;

/* 64-bit LCG step, XSH-RR output of the old state. */
static uint32_t pcg32_random_r(pcg32_random_t *rng)
{
    uint64_t oldstate = rng->state;
    uint32_t xorshifted, rot;
    rng->state = oldstate * 6364136223846793005ULL + (rng->inc | 1u);
    xorshifted = (uint32_t)(((oldstate >> 18u) ^ oldstate) >> 27u);
    rot = (uint32_t)(oldstate >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((0u - rot) & 31u));
}

static void pcg32_srandom_r(pcg32_random_t *rng, uint64_t initstate, uint64_t initseq)
{
    rng->state = 0u;
    rng->inc = (initseq << 1u) | 1u;
    pcg32_random_r(rng);
    rng->state += initstate;
    pcg32_random_r(rng);
}

static float reference_float(pcg32_random_t *rng)
{
    return (float)(pcg32_random_r(rng) >> 8) * (1.0f / 16777216.0f);
}

/* 10^5 draws of msbsdf_rng_next_float against the reference; returns the
   number of mismatches (value or state). */
static long compare_stream(uint64_t seed, uint64_t stream, long draws)
{
    pcg32_random_t ref;
    msbsdf_rng r;
    long i, bad = 0, out_of_range = 0;
    pcg32_srandom_r(&ref, seed, stream);
    msbsdf_rng_seed(&r, seed, stream);
    CHECK(r.state == ref.state && r.inc == ref.inc,
          "seed %llu stream %llu: state/inc %016llx/%016llx, reference %016llx/%016llx",
          (unsigned long long)seed, (unsigned long long)stream, (unsigned long long)r.state,
          (unsigned long long)r.inc, (unsigned long long)ref.state, (unsigned long long)ref.inc);
    for (i = 0; i < draws; i++) {
        float want = reference_float(&ref);
        float got = msbsdf_rng_next_float(&r);
        if (!SAME_BITS(got, want) || r.state != ref.state || r.inc != ref.inc) {
            if (bad < 5) {
                printf("  draw %ld: got %.9g, reference %.9g\n", i, got, want);
            }
            bad++;
        }
        out_of_range += !(got >= 0.0f && got < 1.0f);
    }
    CHECK(bad == 0, "seed %llu stream %llu: %ld of %ld floats differ from the reference",
          (unsigned long long)seed, (unsigned long long)stream, bad, draws);
    CHECK(out_of_range == 0, "seed %llu stream %llu: %ld floats outside [0, 1)",
          (unsigned long long)seed, (unsigned long long)stream, out_of_range);
    return bad;
}

int main(void)
{
    static const uint32_t published[6] = {0xa15c02b7u, 0x7b47f409u, 0xba1d3330u,
                                          0x83d2f293u, 0xbfa4784bu, 0xcbed606eu};
    pcg32_random_t ref;
    msbsdf_rng r;
    int i;

    /* The reference implementation reproduces the published pcg32-demo
       values; msbsdf_rng_seed gives its state, and the state drives the
       reference generator to the same outputs (state is interchangeable). */
    pcg32_srandom_r(&ref, 42u, 54u);
    msbsdf_rng_seed(&r, 42u, 54u);
    CHECK(r.state == ref.state && r.inc == ref.inc, "seed 42/54 state differs from reference");
    {
        pcg32_random_t from_lib;
        from_lib.state = r.state;
        from_lib.inc = r.inc;
        for (i = 0; i < 6; i++) {
            uint32_t a = pcg32_random_r(&ref), b = pcg32_random_r(&from_lib);
            CHECK(a == published[i], "reference pcg32 output %d: %08x, published %08x", i,
                  (unsigned)a, (unsigned)published[i]);
            CHECK(b == published[i], "pcg32 from msbsdf_rng_seed state, output %d: %08x, "
                  "published %08x", i, (unsigned)b, (unsigned)published[i]);
        }
    }
    /* The library's floats are the top 24 bits of those outputs. */
    for (i = 0; i < 6; i++) {
        float got = msbsdf_rng_next_float(&r);
        float want = (float)(published[i] >> 8) * (1.0f / 16777216.0f);
        CHECK(SAME_BITS(got, want), "seed 42/54 float %d: %.9g, expected %.9g", i, got, want);
    }

    compare_stream(42u, 54u, 100000);
    compare_stream(0u, 0u, 100000);
    compare_stream(0xffffffffffffffffULL, 0xffffffffffffffffULL, 20000);
    compare_stream(0x853c49e6748fea9bULL, 0xda3e39cb94b95bdbULL, 20000);
    /* Streams differing only in the top bit are the same stream (inc =
       stream << 1 | 1), as in the reference. */
    compare_stream(7u, 0x8000000000000003ULL, 20000);

    /* A state written by the caller (e.g. deserialised) is used as is,
       including an even inc (the step uses inc | 1, as the reference). */
    {
        pcg32_random_t a;
        msbsdf_rng b;
        long bad = 0;
        a.state = b.state = 0x0123456789abcdefULL;
        a.inc = b.inc = 0x2468ace0u;
        for (i = 0; i < 1000; i++) {
            float want = reference_float(&a), got = msbsdf_rng_next_float(&b);
            bad += !SAME_BITS(got, want);
        }
        CHECK(bad == 0, "caller-written state: %ld floats differ", bad);
        CHECK(b.state == a.state && b.inc == a.inc, "caller-written state diverged");
    }
    return check_finish("rng");
}

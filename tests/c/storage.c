/*
 * msbsdf_material_init in caller storage: works on the stack (C99 union for
 * alignment) and in an arena, gives bit-identical results to
 * msbsdf_material_create, refuses storage that is too small or misaligned
 * without writing it, and msbsdf_material_destroy on it is a no-op.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

#define CANARY 0xA5

/* Compile-time bound on msbsdf_material_size() (checked at run time; the
   header gives no constant, so C callers must pick one). */
#define STORAGE_BYTES 4096
typedef union storage {
    unsigned char bytes[STORAGE_BYTES];
    uint64_t u64;
    double d;
    long double ld;
    void *p;
} storage;
struct storage_align_probe {
    char c;
    storage s;
};
#define STORAGE_ALIGN offsetof(struct storage_align_probe, s)

static msbsdf_vec3 v3(float x, float y, float z)
{
    msbsdf_vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

static msbsdf_material_desc make_desc(int glass)
{
    msbsdf_material_desc d = msbsdf_material_desc_default();
    d.model = MSBSDF_MODEL_SINGLE;
    if (glass) {
        d.ndf = MSBSDF_NDF_GGX;
        d.facet = MSBSDF_FACET_DIELECTRIC;
        d.alpha_x = d.alpha_y = 0.3f;
        d.eta.r = d.eta.g = d.eta.b = 1.5f;
    } else {
        d.ndf = MSBSDF_NDF_BECKMANN;
        d.facet = MSBSDF_FACET_CONDUCTOR;
        d.alpha_x = 0.2f;
        d.alpha_y = 0.6f; /* anisotropic */
        d.eta.r = 0.143f, d.eta.g = 0.374f, d.eta.b = 1.442f;
        d.k.r = 3.983f, d.k.g = 2.385f, d.k.b = 1.603f;
    }
    return d;
}

/* Number of queries where a and b differ in any output bit. */
static long compare_materials(const msbsdf_material *a, const msbsdf_material *b, int n)
{
    msbsdf_rng ra, rb, dirs;
    long diff = 0;
    int i;
    msbsdf_rng_seed(&ra, 99, 1);
    msbsdf_rng_seed(&rb, 99, 1);
    msbsdf_rng_seed(&dirs, 5, 5);
    for (i = 0; i < n; i++) {
        float z = 2.0f * msbsdf_rng_next_float(&dirs) - 1.0f;
        float phi = 6.2831853f * msbsdf_rng_next_float(&dirs);
        float s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
        msbsdf_vec3 wi = v3(s * cosf(phi), s * sinf(phi), z);
        msbsdf_vec3 wo = v3(msbsdf_rng_next_float(&dirs) - 0.5f,
                            msbsdf_rng_next_float(&dirs) - 0.5f, msbsdf_rng_next_float(&dirs));
        msbsdf_sample_result sa, sb;
        msbsdf_rgb fa, fb;
        float pa, pb;
        msbsdf_status s1 = msbsdf_sample(a, wi, &ra, &sa), s2 = msbsdf_sample(b, wi, &rb, &sb);
        msbsdf_status s3 = msbsdf_eval(a, wi, wo, &ra, &fa), s4 = msbsdf_eval(b, wi, wo, &rb, &fb);
        msbsdf_status s5 = msbsdf_pdf(a, wi, sa.wo, &pa), s6 = msbsdf_pdf(b, wi, sb.wo, &pb);
        diff += s1 != s2 || s3 != s4 || s5 != s6 || !SAME_BITS(sa, sb) || !SAME_BITS(fa, fb) ||
                !SAME_BITS(pa, pb) || !SAME_BITS(ra, rb);
    }
    return diff;
}

int main(void)
{
    const size_t size = msbsdf_material_size(), align = msbsdf_material_align();
    storage st; /* on the stack */
    msbsdf_material *created[2] = {NULL, NULL};
    int g;

    printf("msbsdf_material_size() = %u, msbsdf_material_align() = %u, union align %u\n",
           (unsigned)size, (unsigned)align, (unsigned)STORAGE_ALIGN);
    CHECK(size > 0 && size <= STORAGE_BYTES, "material size %u outside (0, %u]", (unsigned)size,
          (unsigned)STORAGE_BYTES);
    CHECK(align > 0 && (align & (align - 1)) == 0, "material align %u not a power of two",
          (unsigned)align);
    CHECK(align <= STORAGE_ALIGN, "material align %u larger than a C99 union's %u",
          (unsigned)align, (unsigned)STORAGE_ALIGN);
    CHECK(((uintptr_t)st.bytes % align) == 0, "stack union not aligned");
    if (size == 0 || size > STORAGE_BYTES || align == 0 || align > STORAGE_ALIGN) {
        return check_finish("storage");
    }

    for (g = 0; g < 2; g++) {
        msbsdf_material_desc d = make_desc(g);
        msbsdf_material *m = NULL, *again = NULL;
        const char *name = g ? "glass" : "conductor";
        unsigned char *snapshot;
        long diff;

        CHECK_STATUS(msbsdf_material_create(&d, &created[g]), MSBSDF_STATUS_OK);
        memset(&st, CANARY, sizeof st);
        CHECK_STATUS(msbsdf_material_init(&d, st.bytes, size, &m), MSBSDF_STATUS_OK);
        CHECK(m != NULL, "%s: init OK but *out NULL", name);
        CHECK(all_bytes_are(st.bytes + size, sizeof st - size, CANARY),
              "%s: init wrote past msbsdf_material_size() bytes", name);
        if (m == NULL || created[g] == NULL) {
            continue;
        }
        diff = compare_materials(m, created[g], 5000);
        CHECK(diff == 0, "%s: %ld of 5000 queries differ between init and create", name, diff);

        /* destroy on caller storage: no-op (storage unchanged, still usable). */
        snapshot = (unsigned char *)malloc(size);
        if (snapshot != NULL) {
            memcpy(snapshot, st.bytes, size);
            msbsdf_material_destroy(m);
            CHECK(memcmp(snapshot, st.bytes, size) == 0, "%s: destroy changed caller storage",
                  name);
            free(snapshot);
        }
        diff = compare_materials(m, created[g], 500);
        CHECK(diff == 0, "%s: material unusable after destroy on caller storage", name);

        /* Re-initialising the same storage works. */
        CHECK_STATUS(msbsdf_material_init(&d, st.bytes, sizeof st, &again), MSBSDF_STATUS_OK);
        CHECK(again != NULL && compare_materials(again, created[g], 500) == 0,
              "%s: re-init differs", name);
    }

    /* Too small: nothing written, *out NULL. */
    {
        const size_t small[] = {0, 1, size / 2, size - 1};
        msbsdf_material_desc d = make_desc(0);
        size_t i;
        for (i = 0; i < sizeof small / sizeof small[0]; i++) {
            msbsdf_material *m = (msbsdf_material *)(void *)&st;
            memset(&st, CANARY, sizeof st);
            CHECK_STATUS(msbsdf_material_init(&d, st.bytes, small[i], &m),
                         MSBSDF_STATUS_STORAGE_TOO_SMALL);
            CHECK(m == NULL, "init with %u bytes: *out not NULL", (unsigned)small[i]);
            CHECK(all_bytes_are(&st, sizeof st, CANARY), "init with %u bytes wrote storage",
                  (unsigned)small[i]);
        }
    }

    /* Misaligned: every offset that is not a multiple of the alignment. */
    {
        msbsdf_material_desc d = make_desc(1);
        size_t off;
        if (align == 1) {
            printf("NOTE: msbsdf_material_align() is 1, no misaligned storage exists\n");
        }
        for (off = 1; off < align; off++) {
            msbsdf_material *m = (msbsdf_material *)(void *)&st;
            memset(&st, CANARY, sizeof st);
            CHECK_STATUS(msbsdf_material_init(&d, st.bytes + off, sizeof st - off, &m),
                         MSBSDF_STATUS_STORAGE_MISALIGNED);
            CHECK(m == NULL, "init at offset %u: *out not NULL", (unsigned)off);
            CHECK(all_bytes_are(&st, sizeof st, CANARY), "init at offset %u wrote storage",
                  (unsigned)off);
        }
        /* ...while an offset of one alignment unit is fine. */
        {
            msbsdf_material *m = NULL;
            CHECK_STATUS(msbsdf_material_init(&d, st.bytes + align, sizeof st - align, &m),
                         MSBSDF_STATUS_OK);
            CHECK(m != NULL && compare_materials(m, created[1], 500) == 0,
                  "init at offset align differs from create");
        }
    }

    /* An arena: 8 materials packed at stride round_up(size, align) in one
       malloc block, alternating conductor and glass. */
    {
        const size_t stride = (size + align - 1) / align * align;
        unsigned char *arena = (unsigned char *)malloc(stride * 8 + align);
        if (arena != NULL) {
            unsigned char *base =
                arena + (align - (size_t)((uintptr_t)arena % align)) % align;
            msbsdf_material *ms[8];
            int i;
            for (i = 0; i < 8; i++) {
                msbsdf_material_desc d = make_desc(i & 1);
                ms[i] = NULL;
                CHECK_STATUS(msbsdf_material_init(&d, base + (size_t)i * stride, stride, &ms[i]),
                             MSBSDF_STATUS_OK);
            }
            for (i = 0; i < 8; i++) {
                CHECK(ms[i] != NULL && compare_materials(ms[i], created[i & 1], 300) == 0,
                      "arena material %d differs from create", i);
                msbsdf_material_destroy(ms[i]); /* no-op */
            }
            free(arena);
        }
    }

    msbsdf_material_destroy(created[0]);
    msbsdf_material_destroy(created[1]);
    msbsdf_material_destroy(NULL);
    return check_finish("storage");
}

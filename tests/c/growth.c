/*
 * Struct growth: callers compiled against the 0.2 layout of
 * msbsdf_material_desc (a frozen copy below, 88 bytes, abi/layout.txt at
 * 0.2.0) and against a larger future layout keep working, and the init
 * macros write exactly the caller's struct.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "check.h"

/* msbsdf_material_desc exactly as msbsdf 0.2.0 published it. */
struct desc_0_2 {
    uint32_t struct_size, model, estimator, ndf, facet;
    float alpha_x, alpha_y, shape;
    msbsdf_rgb eta, k, albedo;
    uint32_t max_bounces;
    float tolerance;
    const msbsdf_material *inner;
};

/* A layout from a later version: today's fields and two more. */
struct desc_future {
    msbsdf_material_desc current;
    uint32_t future_u32;
    float future_f32;
};

struct guarded_0_2 {
    struct desc_0_2 d;
    unsigned char canary[32];
};

static msbsdf_rgb eval_at(const msbsdf_material *m, float x, float z)
{
    msbsdf_vec3 wi, wo;
    msbsdf_rgb f;
    wi.x = 0.3f; wi.y = 0.1f; wi.z = 0.9f;
    wo.x = x; wo.y = -0.2f; wo.z = z;
    memset(&f, 0, sizeof f);
    CHECK_STATUS(msbsdf_eval(m, wi, wo, NULL, &f), MSBSDF_STATUS_OK);
    return f;
}

int main(void)
{
    struct guarded_0_2 old;
    struct desc_future fut;
    msbsdf_material_desc cur;
    msbsdf_material *m_old = NULL, *m_cur = NULL, *m_fut = NULL, *bad = NULL;
    msbsdf_rgb f_old, f_cur, f_fut;
    size_t i;
    int canary_kept = 1;

    memset(&f_cur, 0, sizeof f_cur);
    memset(&f_old, 0, sizeof f_old);

    CHECK(sizeof(struct desc_0_2) == 88, "frozen 0.2 layout is %u bytes", (unsigned)sizeof(struct desc_0_2));

    /* The initialiser writes exactly 88 bytes for a 0.2 caller. */
    memset(&old, 0xAB, sizeof old);
    CHECK_STATUS(msbsdf_material_desc_init_sized((msbsdf_material_desc *)(void *)&old.d, sizeof old.d),
                 MSBSDF_STATUS_OK);
    for (i = 0; i < sizeof old.canary; i++)
        canary_kept &= old.canary[i] == 0xAB;
    CHECK(canary_kept, "init of a 0.2 struct wrote past its 88 bytes");
    CHECK(old.d.struct_size == 88, "struct_size %u", (unsigned)old.d.struct_size);
    CHECK(old.d.model == MSBSDF_MODEL_SINGLE && old.d.ndf == MSBSDF_NDF_GGX && old.d.alpha_x == 0.5f &&
              old.d.k.g == 1.0f && old.d.inner == NULL,
          "0.2 defaults wrong");

    /* The same gold material through the three layouts. */
    msbsdf_material_desc_init(&cur);
    CHECK(cur.struct_size == sizeof cur, "init macro struct_size %u", (unsigned)cur.struct_size);
    CHECK(cur.conductor_sides == MSBSDF_CONDUCTOR_TWO_SIDED, "default sides");
    memset(&fut, 0x5A, sizeof fut);
    CHECK_STATUS(msbsdf_material_desc_init_sized(&fut.current, sizeof fut), MSBSDF_STATUS_OK);
    CHECK(fut.current.struct_size == sizeof fut, "future struct_size %u", (unsigned)fut.current.struct_size);
    CHECK(fut.future_u32 == 0 && fut.future_f32 == 0.0f, "unknown fields of a newer layout are zeroed");

    old.d.alpha_x = cur.alpha_x = fut.current.alpha_x = 0.3f;
    old.d.alpha_y = cur.alpha_y = fut.current.alpha_y = 0.45f;
    old.d.eta.r = cur.eta.r = fut.current.eta.r = 0.143f;
    old.d.eta.g = cur.eta.g = fut.current.eta.g = 0.374f;
    old.d.eta.b = cur.eta.b = fut.current.eta.b = 1.442f;
    old.d.k.r = cur.k.r = fut.current.k.r = 3.983f;
    old.d.k.g = cur.k.g = fut.current.k.g = 2.385f;
    old.d.k.b = cur.k.b = fut.current.k.b = 1.603f;
    fut.future_u32 = 7; /* a field this library does not know: ignored */
    fut.future_f32 = 3.5f;
    CHECK_STATUS(msbsdf_material_create((const msbsdf_material_desc *)(const void *)&old.d, &m_old),
                 MSBSDF_STATUS_OK);
    CHECK_STATUS(msbsdf_material_create(&cur, &m_cur), MSBSDF_STATUS_OK);
    CHECK_STATUS(msbsdf_material_create(&fut.current, &m_fut), MSBSDF_STATUS_OK);
    if (m_old && m_cur && m_fut) {
        f_old = eval_at(m_old, -0.4f, 0.8f);
        f_cur = eval_at(m_cur, -0.4f, 0.8f);
        f_fut = eval_at(m_fut, -0.4f, 0.8f);
        CHECK(f_cur.r > 0.0f, "eval %g", (double)f_cur.r);
        CHECK(SAME_BITS(f_old, f_cur) && SAME_BITS(f_fut, f_cur), "layouts disagree: %g %g %g",
              (double)f_old.g, (double)f_cur.g, (double)f_fut.g);
        /* A 0.2 caller gets the default (two-sided) conductor: the back face scatters. */
        f_old = eval_at(m_old, -0.4f, 0.8f);
        {
            msbsdf_vec3 wi, wo;
            msbsdf_rgb f;
            wi.x = 0.3f; wi.y = 0.1f; wi.z = -0.9f;
            wo.x = -0.4f; wo.y = -0.2f; wo.z = -0.8f;
            CHECK_STATUS(msbsdf_eval(m_old, wi, wo, NULL, &f), MSBSDF_STATUS_OK);
            CHECK(SAME_BITS(f, f_old), "two-sided: back face = front face");
        }
    }
    /* msbsdf_material_init reads the 0.2 layout the same way. */
    {
        static union {
            unsigned char bytes[4096];
            long double align_ld;
            void *align_p;
            uint64_t align_u64;
        } st;
        msbsdf_material *in_storage = NULL;
        CHECK(msbsdf_material_size() <= sizeof st.bytes, "storage %u", (unsigned)msbsdf_material_size());
        CHECK_STATUS(msbsdf_material_init((const msbsdf_material_desc *)(const void *)&old.d, st.bytes,
                                          sizeof st.bytes, &in_storage),
                     MSBSDF_STATUS_OK);
        if (in_storage && m_cur) {
            msbsdf_rgb a = eval_at(in_storage, -0.4f, 0.8f), b = eval_at(m_cur, -0.4f, 0.8f);
            CHECK(SAME_BITS(a, b), "init from the 0.2 layout differs");
        }
    }
    /* One-sided conductors through the appended field. */
    cur.conductor_sides = MSBSDF_CONDUCTOR_ONE_SIDED;
    {
        msbsdf_material *one = NULL;
        msbsdf_vec3 wi, wo;
        msbsdf_rgb f;
        CHECK_STATUS(msbsdf_material_create(&cur, &one), MSBSDF_STATUS_OK);
        wi.x = 0.3f; wi.y = 0.1f; wi.z = -0.9f;
        wo.x = -0.4f; wo.y = -0.2f; wo.z = -0.8f;
        CHECK_STATUS(msbsdf_eval(one, wi, wo, NULL, &f), MSBSDF_STATUS_OK);
        CHECK(f.r == 0.0f && f.g == 0.0f && f.b == 0.0f, "one-sided: back face absorbs");
        f = eval_at(one, -0.4f, 0.8f);
        CHECK(SAME_BITS(f, f_cur), "one-sided: front face unchanged");
        msbsdf_material_destroy(one);
    }
    cur.conductor_sides = 7;
    CHECK_STATUS(msbsdf_material_create(&cur, &bad), MSBSDF_STATUS_UNKNOWN_CONSTANT);
    cur.conductor_sides = MSBSDF_CONDUCTOR_TWO_SIDED;

    /* Sizes below the 0.2 layout are refused, and nothing is written. */
    old.d.struct_size = 84;
    CHECK_STATUS(msbsdf_material_create((const msbsdf_material_desc *)(const void *)&old.d, &bad),
                 MSBSDF_STATUS_STRUCT_TOO_SMALL);
    CHECK(bad == NULL, "no material on failure");
    memset(&old, 0xAB, sizeof old);
    CHECK_STATUS(msbsdf_material_desc_init_sized((msbsdf_material_desc *)(void *)&old.d, 87),
                 MSBSDF_STATUS_STRUCT_TOO_SMALL);
    CHECK(old.d.struct_size == 0xABABABABu, "refused init wrote nothing");
    CHECK_STATUS(msbsdf_material_desc_init_sized(NULL, sizeof cur), MSBSDF_STATUS_NULL_POINTER);

    /* The context and the sample record grow the same way. */
    {
        struct { msbsdf_context c; uint64_t more; } ctx;
        struct { msbsdf_sample_record r; float more[3]; } rec;
        msbsdf_vec3 wi;
        memset(&ctx, 0x77, sizeof ctx);
        memset(&rec, 0x77, sizeof rec);
        CHECK_STATUS(msbsdf_context_init_sized(&ctx.c, sizeof ctx), MSBSDF_STATUS_OK);
        CHECK(ctx.more == 0 && ctx.c.transport == MSBSDF_TRANSPORT_RADIANCE && ctx.c.lobes == MSBSDF_LOBE_ALL &&
                  ctx.c.rng == NULL,
              "context defaults");
        rec.r.struct_size = sizeof rec;
        wi.x = 0.3f; wi.y = 0.1f; wi.z = 0.9f;
        CHECK_STATUS(msbsdf_sample_with(m_cur, &ctx.c, wi, 0.5f, 0.25f, 0.75f, &rec.r), MSBSDF_STATUS_OK);
        CHECK(rec.r.struct_size == sizeof rec && rec.more[0] == 0.0f && rec.more[2] == 0.0f,
              "record tail zeroed, struct_size kept");
        CHECK(rec.r.flags == (MSBSDF_SAMPLE_REFLECTION | MSBSDF_SAMPLE_GLOSSY), "flags %u", (unsigned)rec.r.flags);
        rec.r.struct_size = sizeof rec.r - 4;
        CHECK_STATUS(msbsdf_sample_with(m_cur, &ctx.c, wi, 0.5f, 0.25f, 0.75f, &rec.r),
                     MSBSDF_STATUS_STRUCT_TOO_SMALL);
        ctx.c.struct_size = 8;
        rec.r.struct_size = sizeof rec.r;
        CHECK_STATUS(msbsdf_sample_with(m_cur, &ctx.c, wi, 0.5f, 0.25f, 0.75f, &rec.r),
                     MSBSDF_STATUS_STRUCT_TOO_SMALL);
    }

    msbsdf_material_destroy(m_old);
    msbsdf_material_destroy(m_cur);
    msbsdf_material_destroy(m_fut);
    return check_finish("growth");
}

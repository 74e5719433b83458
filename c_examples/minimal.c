/*
 * minimal.c: the smallest useful msbsdf program.
 *
 * Creates two single-scattering materials (rough gold, GGX alpha 0.5, and
 * rough glass, eta 1.5, GGX alpha 0.3), prints eval / sample / pdf for a few
 * directions and a directional-albedo table estimated from sample weights
 * with a fixed seed. Build: `make` (after `cargo build --release` in the
 * repository root), run: `./minimal`.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "msbsdf.h"

#define SAMPLES 20000

static msbsdf_vec3 dir_deg(float theta_deg, float phi_deg)
{
    const float d2r = 3.14159265f / 180.0f;
    msbsdf_vec3 v;
    v.x = sinf(theta_deg * d2r) * cosf(phi_deg * d2r);
    v.y = sinf(theta_deg * d2r) * sinf(phi_deg * d2r);
    v.z = cosf(theta_deg * d2r);
    return v;
}

/* Prints the reason and exits when a call fails. */
static void check(msbsdf_status s, const char *what)
{
    if (s != MSBSDF_STATUS_OK) {
        fprintf(stderr, "%s failed: %s (status %u)\n", what, msbsdf_status_message(s),
                (unsigned)s);
        exit(1);
    }
}

static void show_queries(const msbsdf_material *m, const char *name)
{
    const float thetas[3] = {0.0f, 45.0f, 75.0f};
    msbsdf_rng rng;
    int i;
    msbsdf_rng_seed(&rng, 42, 54);
    printf("%s\n", name);
    for (i = 0; i < 3; i++) {
        msbsdf_vec3 wi = dir_deg(thetas[i], 0.0f);
        msbsdf_vec3 wo = dir_deg(30.0f, 180.0f);   /* reflection side */
        msbsdf_vec3 wt = dir_deg(160.0f, 180.0f);  /* transmission side */
        msbsdf_rgb f, ft;
        float p, pt;
        msbsdf_sample_result s;
        check(msbsdf_eval(m, wi, wo, &rng, &f), "msbsdf_eval");
        check(msbsdf_pdf(m, wi, wo, &p), "msbsdf_pdf");
        check(msbsdf_eval(m, wi, wt, &rng, &ft), "msbsdf_eval");
        check(msbsdf_pdf(m, wi, wt, &pt), "msbsdf_pdf");
        check(msbsdf_sample(m, wi, &rng, &s), "msbsdf_sample");
        printf("  theta_i %2.0f: f|cos| to 30 deg = (%.4f %.4f %.4f) pdf %.4f;"
               " to 160 deg = (%.4f %.4f %.4f) pdf %.4f\n",
               thetas[i], f.r, f.g, f.b, p, ft.r, ft.g, ft.b, pt);
        printf("               sample: wo (%+.3f %+.3f %+.3f) weight (%.4f %.4f %.4f) pdf %.4f %s\n",
               s.wo.x, s.wo.y, s.wo.z, s.weight.r, s.weight.g, s.weight.b, s.pdf,
               s.flags == MSBSDF_SAMPLE_REFLECTION     ? "reflection"
               : s.flags == MSBSDF_SAMPLE_TRANSMISSION ? "transmission"
                                                       : "absorbed");
    }
}

int main(void)
{
    msbsdf_material_desc gd, dd;
    msbsdf_material *gold = NULL, *glass = NULL;
    msbsdf_rng rng;
    int t, i;

    msbsdf_material_desc_init(&gd); /* defaults, written at this program's sizeof */
    msbsdf_material_desc_init(&dd);

    printf("msbsdf %u.%u.%u\n", (unsigned)(msbsdf_version() >> 16),
           (unsigned)((msbsdf_version() >> 8) & 0xff), (unsigned)(msbsdf_version() & 0xff));

    /* Rough gold: conductor facets, complex IOR per RGB channel. */
    gd.model = MSBSDF_MODEL_SINGLE;
    gd.ndf = MSBSDF_NDF_GGX;
    gd.facet = MSBSDF_FACET_CONDUCTOR;
    gd.alpha_x = gd.alpha_y = 0.5f;
    gd.eta.r = 0.143f, gd.eta.g = 0.374f, gd.eta.b = 1.442f;
    gd.k.r = 3.983f, gd.k.g = 2.385f, gd.k.b = 1.603f;
    check(msbsdf_material_create(&gd, &gold), "create gold");

    /* Rough glass: dielectric facets, eta.r = inside / outside index. */
    dd.model = MSBSDF_MODEL_SINGLE;
    dd.ndf = MSBSDF_NDF_GGX;
    dd.facet = MSBSDF_FACET_DIELECTRIC;
    dd.alpha_x = dd.alpha_y = 0.3f;
    dd.eta.r = 1.5f;
    check(msbsdf_material_create(&dd, &glass), "create glass");

    show_queries(gold, "gold, GGX alpha 0.5");
    show_queries(glass, "glass, eta 1.5, GGX alpha 0.3");

    /* Directional albedo: the mean sample weight (f |cos| / pdf) over
       SAMPLES samples; glass split into reflection R and transmission T. */
    printf("\ndirectional albedo, %d samples per angle, seed 42 stream 54\n", SAMPLES);
    printf("theta_i  gold_r  gold_g  gold_b  glass_R  glass_T  glass_R+T\n");
    msbsdf_rng_seed(&rng, 42, 54);
    for (t = 0; t <= 80; t += 10) {
        msbsdf_vec3 wi = dir_deg((float)t, 0.0f);
        double g[3] = {0.0, 0.0, 0.0}, r = 0.0, tr = 0.0;
        for (i = 0; i < SAMPLES; i++) {
            msbsdf_sample_result s;
            check(msbsdf_sample(gold, wi, &rng, &s), "msbsdf_sample");
            g[0] += s.weight.r;
            g[1] += s.weight.g;
            g[2] += s.weight.b;
            check(msbsdf_sample(glass, wi, &rng, &s), "msbsdf_sample");
            if (s.flags == MSBSDF_SAMPLE_REFLECTION) {
                r += s.weight.r;
            } else if (s.flags == MSBSDF_SAMPLE_TRANSMISSION) {
                tr += s.weight.r;
            }
        }
        printf("%7d  %6.4f  %6.4f  %6.4f  %7.4f  %7.4f  %9.4f\n", t, g[0] / SAMPLES,
               g[1] / SAMPLES, g[2] / SAMPLES, r / SAMPLES, tr / SAMPLES, (r + tr) / SAMPLES);
    }
    printf("\n(single scattering loses energy at high roughness and grazing angles;\n"
           " the multiple-scattering models restore it)\n");

    msbsdf_material_destroy(gold);
    msbsdf_material_destroy(glass);
    return 0;
}

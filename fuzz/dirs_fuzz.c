/*
 * libFuzzer harness: bytes -> a material from a fixed table (every model
 * constant x NDF x facet x a few roughnesses; the ones create refuses as
 * UNSUPPORTED are skipped, so the harness covers new models as they land)
 * -> direction triples -> eval / sample / pdf, and the context calls
 * (eval_pdf, sample_with) with a fuzzed context and uniforms. Outputs must be finite and
 * non-negative, statuses in the known set, failures zeroed (fuzz_common.h).
 *
 * Build and run: fuzz/run.sh dirs_fuzz SECONDS. The corpus in
 * fuzz/corpus/dirs_fuzz is replayed by tests/fuzz_corpus.rs.
 */
#include "fuzz_common.h"

/* Every model constant: 0 .. MSBSDF_MODEL_TABULATED. */
#define N_MODELS (MSBSDF_MODEL_TABULATED + 1)
#define N_NDFS 7
#define N_FACETS 3
#define N_ALPHAS 5
#define N_MATERIALS (N_MODELS * N_NDFS * N_FACETS * N_ALPHAS)

static msbsdf_material *materials[N_MATERIALS];
static int exact_pdf[N_MATERIALS];
static float alpha_min[N_MATERIALS];
static int n_materials = -1;

static void build_materials(void)
{
    /* 0 and 1e-4: the specular regime; 0.1 to 10 glossy. */
    static const float alphas[N_ALPHAS] = {0.0f, 1e-4f, 0.1f, 0.7f, 10.0f};
    int model, ndf, facet, a;
    n_materials = 0;
    for (model = 0; model < N_MODELS; model++) {
        for (ndf = 0; ndf < N_NDFS; ndf++) {
            for (facet = 0; facet < N_FACETS; facet++) {
                for (a = 0; a < N_ALPHAS; a++) {
                    msbsdf_material_desc d = msbsdf_material_desc_default();
                    msbsdf_material *m = NULL;
                    d.model = (uint32_t)model;
                    d.ndf = (uint32_t)ndf;
                    d.facet = (uint32_t)facet;
                    d.alpha_x = alphas[a];
                    d.alpha_y = alphas[(a + (model & 1)) % N_ALPHAS];
                    d.shape = 2.5f;
                    d.tolerance = 0.1f; /* AUTO: a cheap choice (see desc_fuzz.c) */
                    if (facet == MSBSDF_FACET_CONDUCTOR && (a & 1)) {
                        d.eta.r = 0.143f, d.eta.g = 0.374f, d.eta.b = 1.442f;
                        d.k.r = 3.983f, d.k.g = 2.385f, d.k.b = 1.603f;
                    }
                    if (facet == MSBSDF_FACET_DIELECTRIC) {
                        d.eta.r = d.eta.g = d.eta.b = (a & 1) ? 1.5f : 1.0f / 1.33f;
                    }
                    if (msbsdf_material_create(&d, &m) == MSBSDF_STATUS_OK) {
#ifdef FUZZ_TRACE
                        fprintf(stderr, "material %d: model %d ndf %d facet %d alpha %g %g eta %g\n",
                                n_materials, model, ndf, facet, d.alpha_x, d.alpha_y, d.eta.r);
#endif
                        exact_pdf[n_materials] = fz_model_has_exact_pdf(d.model);
                        alpha_min[n_materials] = fminf(d.alpha_x, d.alpha_y);
                        materials[n_materials++] = m;
                    }
                }
            }
        }
    }
    if (n_materials == 0) {
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_reader r;
    const msbsdf_material *m;
    msbsdf_rng rng;
    int q;
    if (n_materials < 0) {
        build_materials();
    }
    r.p = data;
    r.n = size;
    {
        int i = fz_u16(&r) % n_materials;
        m = materials[i];
#ifdef FUZZ_TRACE
        fprintf(stderr, "using material %d\n", i);
#endif
        fz_exact_pdf = exact_pdf[i];
        fz_set_alpha(alpha_min[i], alpha_min[i]);
    }
    fz_seed(&r, &rng);
    for (q = 0; q < 8 && (q == 0 || r.n > 0); q++) {
        msbsdf_vec3 wi = fz_dir(&r);
        msbsdf_vec3 wo = fz_dir(&r);
        fz_query(m, wi, wo, &rng);
        fz_query_ctx(m, wi, wo, (q & 1) ? &rng : NULL, &r);
    }
    return 0;
}

// OBJ loading through tinyobjloader (C++), behind a C interface (tracer.h).
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>

#include <tiny_obj_loader.h>

#include "tracer.h"

extern "C" int obj_load(const char *path, obj_mesh *out, char *err, size_t errlen) {
    std::memset(out, 0, sizeof *out);
    try {
        tinyobj::ObjReaderConfig cfg;
        cfg.triangulate = true;
        cfg.vertex_color = false;
        tinyobj::ObjReader reader;
        if (!reader.ParseFromFile(path, cfg)) {
            std::string e = reader.Error();
            while (!e.empty() && (e.back() == '\n' || e.back() == '\r' || e.back() == ' ')) e.pop_back();
            std::snprintf(err, errlen, "cannot load OBJ '%s': %s", path, e.empty() ? "unknown error" : e.c_str());
            return -1;
        }
        const tinyobj::attrib_t &a = reader.GetAttrib();
        size_t ntris = 0;
        bool normals = !a.normals.empty(), uvs = !a.texcoords.empty();
        for (const auto &sh : reader.GetShapes()) ntris += sh.mesh.num_face_vertices.size();
        if (ntris == 0 || ntris > (1u << 26)) {
            std::snprintf(err, errlen, "OBJ '%s' has %zu triangles (need 1 to 2^26)", path, ntris);
            return -1;
        }
        out->pos = static_cast<float *>(std::calloc(ntris * 9, sizeof(float)));
        out->nrm = normals ? static_cast<float *>(std::calloc(ntris * 9, sizeof(float))) : nullptr;
        out->uv = uvs ? static_cast<float *>(std::calloc(ntris * 6, sizeof(float))) : nullptr;
        if (!out->pos || (normals && !out->nrm) || (uvs && !out->uv)) throw std::bad_alloc();
        size_t t = 0;
        for (const auto &sh : reader.GetShapes()) {
            size_t off = 0;
            for (size_t f = 0; f < sh.mesh.num_face_vertices.size(); f++) {
                size_t fv = sh.mesh.num_face_vertices[f];
                if (fv != 3) throw std::runtime_error("face with " + std::to_string(fv) + " vertices after triangulation");
                bool face_has_n = true;
                for (size_t c = 0; c < 3; c++) {
                    const tinyobj::index_t &ix = sh.mesh.indices[off + c];
                    if (ix.vertex_index < 0 || 3 * size_t(ix.vertex_index) + 2 >= a.vertices.size())
                        throw std::runtime_error("vertex index out of range");
                    for (int k = 0; k < 3; k++) out->pos[9 * t + 3 * c + k] = a.vertices[3 * size_t(ix.vertex_index) + k];
                    if (normals) {
                        if (ix.normal_index >= 0 && 3 * size_t(ix.normal_index) + 2 < a.normals.size())
                            for (int k = 0; k < 3; k++) out->nrm[9 * t + 3 * c + k] = a.normals[3 * size_t(ix.normal_index) + k];
                        else
                            face_has_n = false;
                    }
                    if (uvs && ix.texcoord_index >= 0 && 2 * size_t(ix.texcoord_index) + 1 < a.texcoords.size())
                        for (int k = 0; k < 2; k++) out->uv[6 * t + 2 * c + k] = a.texcoords[2 * size_t(ix.texcoord_index) + k];
                }
                if (normals && !face_has_n) { /* no normals on this face: use the flat one */
                    const float *p = out->pos + 9 * t;
                    float e1[3] = {p[3] - p[0], p[4] - p[1], p[5] - p[2]}, e2[3] = {p[6] - p[0], p[7] - p[1], p[8] - p[2]};
                    float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
                    for (size_t c = 0; c < 3; c++)
                        for (int k = 0; k < 3; k++) out->nrm[9 * t + 3 * c + k] = n[k];
                }
                off += fv;
                t++;
            }
        }
        out->ntris = int(ntris);
        return 0;
    } catch (const std::exception &e) {
        std::free(out->pos), std::free(out->nrm), std::free(out->uv);
        std::memset(out, 0, sizeof *out);
        std::snprintf(err, errlen, "cannot load OBJ '%s': %s", path, e.what());
        return -1;
    }
}

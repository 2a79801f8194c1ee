/* SPDX-License-Identifier: MIT
 *
 * Copyright (c) 2026 the vgeo authors
 *
 * Permission is hereby granted, free of charge, to any person obtaining a copy
 * of this software and associated documentation files (the "Software"), to deal
 * in the Software without restriction, including without limitation the rights
 * to use, copy, modify, merge, publish, distribute, sublicense, and/or sell
 * copies of the Software, and to permit persons to whom the Software is
 * furnished to do so, subject to the following conditions:
 *
 * The above copyright notice and this permission notice shall be included in all
 * copies or substantial portions of the Software.
 *
 * THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR
 * IMPLIED, INCLUDING BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY,
 * FITNESS FOR A PARTICULAR PURPOSE AND NONINFRINGEMENT. IN NO EVENT SHALL THE
 * AUTHORS OR COPYRIGHT HOLDERS BE LIABLE FOR ANY CLAIM, DAMAGES OR OTHER
 * LIABILITY, WHETHER IN AN ACTION OF CONTRACT, TORT OR OTHERWISE, ARISING FROM,
 * OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE
 * SOFTWARE.
 */
/* vgeodag_writer.h — write a cluster DAG as a VGEODAG1 file (spec/dag.md §7) from plain arrays.
 *
 * Single file, C99, no dependencies beyond the C standard library (libm: sqrt, nextafterf).
 * Part of vgeo, under the MIT license (the notice above; LICENSE at the repository root).
 *
 * Use: in ONE C or C++ file
 *     #define VGEODAG_WRITER_IMPLEMENTATION
 *     #include "vgeodag_writer.h"
 * and include it without the define anywhere else.
 *
 * What you fill (spec/dag.md §1 and §8 say what each value must promise):
 *   - clusters sorted by group, groups sorted by level, a group's members contiguous;
 *   - per cluster: vertex/triangle ranges, group, generating_group (VGEODAG_NONE for leaves),
 *     level; per group: member range, generated range, level, flags (VGEODAG_GROUP_TERMINAL
 *     for roots), parent_error (+inf = VGEODAG_TERMINAL_ERROR for terminal groups);
 *   - vertex positions (3 floats per vertex, each cluster has its own copies, local 8-bit
 *     indices), optional normals/uvs, per-triangle materials (NULL = all 0).
 * Then call vgeodag_derive() to compute every sphere and every shared value (lod_error,
 * lod_bounds, parent_error, parent_bounds, mesh bounds, level_count) the way spec/dag.md §8
 * describes, and vgeodag_write_file(). If bvh_nodes is NULL the writer emits a BVH8 over the
 * groups itself. A builder that keeps its own spheres may fill them and skip vgeodag_derive();
 * vgeodag_enclose_*() round outward so that containment holds with zero tolerance.
 *
 * All functions return VGEODAG_OK (0) or a negative vgeodag_result. Nothing is written to
 * stdout/stderr. The file is written to "path.tmp" and renamed over path (a previous file is
 * left as it was on failure).
 */
#ifndef VGEODAG_WRITER_H
#define VGEODAG_WRITER_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define VGEODAG_NONE 0xFFFFFFFFu            /* "no index": leaves' generating_group, unused BVH slots */
#define VGEODAG_GROUP_TERMINAL 1u           /* group flag bit 0: not simplified, members are roots */
#define VGEODAG_TERMINAL_ERROR INFINITY    /* parent_error of terminal groups: +inf */
#define VGEODAG_MAX_CLUSTER_TRIANGLES 128u  /* vgeo's limits (spec/dag.md D1), checked on read */
#define VGEODAG_MAX_CLUSTER_VERTICES 255u
#define VGEODAG_BVH_MAX_CHILDREN 8u
#define VGEODAG_MESH_HAS_NORMALS 1u
#define VGEODAG_MESH_HAS_UVS 2u

typedef enum vgeodag_result {
  VGEODAG_OK = 0,
  VGEODAG_ERROR_ARGUMENT = -1, /* a NULL array with a non-zero count, or a range outside its array */
  VGEODAG_ERROR_ORDER = -2,    /* vgeodag_derive: groups not sorted by level, or a generating group not below */
  VGEODAG_ERROR_MEMORY = -3,   /* malloc failed */
  VGEODAG_ERROR_IO = -4        /* cannot open, write or rename */
} vgeodag_result;

typedef struct vgeodag_sphere {
  float x, y, z, r;
} vgeodag_sphere;

typedef struct vgeodag_cluster {
  uint32_t vertex_offset, vertex_count;     /* vertices [vertex_offset, +vertex_count) */
  uint32_t triangle_offset, triangle_count; /* triangles [triangle_offset, +triangle_count) */
  uint32_t group;                           /* member of */
  uint32_t generating_group;                /* produced by; VGEODAG_NONE for leaves */
  uint32_t level;                           /* 0 for leaves */
  vgeodag_sphere bounds, lod_bounds, parent_bounds; /* filled by vgeodag_derive() */
  float lod_error, parent_error;                    /* filled by vgeodag_derive() */
} vgeodag_cluster;

/* parent_error, the one definition (spec/dag.md D6, spec/invariants.md §5): for a non-terminal
 * group, a value >= max(every member's lod_error, D), where D is the largest distance from a
 * point of the triangles this group generated to the nearest LEAF (level-0) triangle — the
 * deviation from the original surface, not from the group's own input, and a maximum, not a
 * sum of per-level errors. `vgeo verify` samples D on a barycentric lattice (3 steps per edge)
 * and reports ERROR_BOUND when it exceeds the stored value; a quadric estimate is not a bound.
 *
 * Winding (spec/dag.md D12): simplified triangles keep the leaves' winding (counter-clockwise
 * seen from the front, facing the way the input surface they replace faced).
 *
 * builder_sphere: your own sphere for the group's simplified result, if you have one. Present
 * iff r > 0; a zero-initialised group (r = 0), a negative or a NaN radius means "none". When
 * present it is folded in FIRST, so when it already encloses every member's lod_bounds (as a
 * builder's sphere of the simplified result usually does) parent_bounds is that sphere, rounded
 * outward by one ulp, rather than a re-fold of the members that can grow up to ~1.26x. */
typedef struct vgeodag_group {
  uint32_t first_cluster, cluster_count;     /* members */
  uint32_t first_generated, generated_count; /* into generated_clusters; 0 iff terminal */
  uint32_t level;                            /* of its members */
  uint32_t flags;                            /* VGEODAG_GROUP_TERMINAL or 0 */
  vgeodag_sphere bounds, parent_bounds;      /* filled by vgeodag_derive() */
  float parent_error; /* yours: >= max(every member's lod_error, deviation of its output from the leaves) */
  vgeodag_sphere builder_sphere; /* optional, present iff r > 0 (zero = absent): folded into parent_bounds first */
} vgeodag_group;

/* A BVH node. Your own BVH: fill child_count, group_mask and children (node 0 the root, every
 * group under exactly one slot), optionally your own spheres in bounds / lod_bounds (present
 * iff r > 0, folded in first as for builder_sphere), then call vgeodag_derive_bvh(). */
typedef struct vgeodag_bvh_node {
  vgeodag_sphere bounds, lod_bounds;
  float max_parent_error;
  uint32_t child_count, group_mask; /* bit i set: children[i] is a group, else a node */
  uint32_t children[VGEODAG_BVH_MAX_CHILDREN]; /* unused: VGEODAG_NONE */
} vgeodag_bvh_node;

typedef struct vgeodag_mesh {
  vgeodag_cluster* clusters;
  uint32_t cluster_count;
  vgeodag_group* groups;
  uint32_t group_count;
  const uint32_t* generated_clusters;
  uint32_t generated_count;
  const vgeodag_bvh_node* bvh_nodes; /* NULL: the writer builds one (bvh_node_count ignored) */
  uint32_t bvh_node_count;
  const float* positions;   /* 3 per vertex */
  const float* normals;     /* 3 per vertex, or NULL */
  const float* uvs;         /* 2 per vertex, or NULL */
  uint32_t vertex_count;
  const uint8_t* indices;   /* 3 per triangle, local to the triangle's cluster */
  const uint32_t* triangle_materials; /* 1 per triangle, or NULL (all material 0) */
  uint32_t triangle_count;
  uint32_t level_count;     /* max level + 1; filled by vgeodag_derive() */
  float bounds_min[3], bounds_max[3]; /* AABB of the leaves' positions; filled by vgeodag_derive() */
} vgeodag_mesh;

typedef struct vgeodag_material {
  const char* name; /* UTF-8, may be NULL or empty */
  float base_color[4];
} vgeodag_material;

typedef struct vgeodag_instance {
  uint32_t mesh;
  float transform[16]; /* column-major */
} vgeodag_instance;

typedef struct vgeodag_scene {
  const vgeodag_mesh* meshes;
  uint32_t mesh_count;                /* ≥ 1 for `vgeo verify` */
  const vgeodag_material* materials;  /* may be 0: every triangle material must then be 0 */
  uint32_t material_count;
  const vgeodag_instance* instances;  /* may be 0: renderers draw each mesh once, untransformed */
  uint32_t instance_count;
} vgeodag_scene;

/* Smallest sphere-like bound of points / spheres, computed in double, centre rounded to float
 * and radius rounded up past every input (plus one float ulp), so `vgeo verify` finds
 * containment with zero tolerance. n = 0 gives (0,0,0; 0). */
vgeodag_sphere vgeodag_enclose_points(const float* xyz, size_t n);
vgeodag_sphere vgeodag_enclose_spheres(const vgeodag_sphere* spheres, size_t n);

/* Computes every sphere and every shared value from the structure, positions and the groups'
 * parent_error (spec/dag.md §8): cluster bounds from its vertices; leaves lod_error 0 and
 * lod_bounds = bounds; group bounds ⊇ member bounds; group parent_bounds ⊇ builder_sphere (when
 * r > 0, folded first) and every member's lod_bounds, terminal groups included; members get the
 * group's parent values and generated clusters get them as their lod values, bit for bit.
 * Terminal groups get parent_error +inf. Needs groups sorted by level and generating groups of
 * lower level. */
int vgeodag_derive(vgeodag_mesh* mesh);

/* Completes YOUR BVH (after vgeodag_derive): for every node reached from node 0, children
 * before parents, bounds ⊇ your node sphere (if r > 0, folded first) and every child's bounds
 * (a group's bounds, a node's bounds), lod_bounds likewise from your sphere and every child
 * group's parent_bounds / child node's lod_bounds, max_parent_error = the largest below.
 * Returns VGEODAG_ERROR_ARGUMENT when the nodes do not form a tree from node 0 (a slot out of
 * range, child_count 0 or > 8, a node reached twice or not at all). Then set
 * mesh->bvh_nodes = nodes, mesh->bvh_node_count = node_count. */
int vgeodag_derive_bvh(const vgeodag_mesh* mesh, vgeodag_bvh_node* nodes, uint32_t node_count);

/* Writes the scene (VGEODAG1, little-endian on every host). */
int vgeodag_write_file(const char* path, const vgeodag_scene* scene);

#ifdef __cplusplus
}
#endif
#endif /* VGEODAG_WRITER_H */

/* ------------------------------------------------------------------------------------------ */
#ifdef VGEODAG_WRITER_IMPLEMENTATION
#ifndef VGEODAG_WRITER_IMPLEMENTED
#define VGEODAG_WRITER_IMPLEMENTED

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double vgeodag__distance(const double a[3], const double b[3]) {
  double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return sqrt(dx * dx + dy * dy + dz * dz);
}

/* Radius that encloses `need` (a double) as a float: rounded up, then one more ulp so the
 * reader's double evaluation of the distance (its own rounding) still finds containment. */
static float vgeodag__radius_up(double need) {
  float r = (float)need;
  while ((double)r < need) r = nextafterf(r, (float)INFINITY);
  return nextafterf(r, (float)INFINITY);
}

vgeodag_sphere vgeodag_enclose_points(const float* xyz, size_t n) {
  vgeodag_sphere s = {0.0f, 0.0f, 0.0f, 0.0f};
  double lo[3], hi[3], c[3], need = 0.0;
  size_t i;
  int k;
  if (n == 0 || !xyz) return s;
  for (k = 0; k < 3; ++k) lo[k] = hi[k] = xyz[k];
  for (i = 1; i < n; ++i)
    for (k = 0; k < 3; ++k) {
      double v = xyz[3 * i + k];
      if (v < lo[k]) lo[k] = v;
      if (v > hi[k]) hi[k] = v;
    }
  s.x = (float)(0.5 * (lo[0] + hi[0]));
  s.y = (float)(0.5 * (lo[1] + hi[1]));
  s.z = (float)(0.5 * (lo[2] + hi[2]));
  c[0] = s.x, c[1] = s.y, c[2] = s.z;
  for (i = 0; i < n; ++i) {
    double p[3], d;
    p[0] = xyz[3 * i], p[1] = xyz[3 * i + 1], p[2] = xyz[3 * i + 2];
    d = vgeodag__distance(c, p);
    if (d > need) need = d;
  }
  s.r = vgeodag__radius_up(need);
  return s;
}

vgeodag_sphere vgeodag_enclose_spheres(const vgeodag_sphere* spheres, size_t n) {
  /* Fold the exact two-sphere union in double for the centre, then take the radius from the
   * float-rounded centre against every input (never from the fold's own radius). */
  vgeodag_sphere s = {0.0f, 0.0f, 0.0f, 0.0f};
  double c[3], r, need = 0.0;
  size_t i;
  if (n == 0 || !spheres) return s;
  c[0] = spheres[0].x, c[1] = spheres[0].y, c[2] = spheres[0].z, r = spheres[0].r;
  for (i = 1; i < n; ++i) {
    double b[3], d;
    b[0] = spheres[i].x, b[1] = spheres[i].y, b[2] = spheres[i].z;
    d = vgeodag__distance(c, b);
    if (d + spheres[i].r <= r) continue;            /* inside already */
    if (d + r <= spheres[i].r) {                    /* swallows the union so far */
      c[0] = b[0], c[1] = b[1], c[2] = b[2], r = spheres[i].r;
      continue;
    }
    {
      double nr = 0.5 * (d + r + spheres[i].r), t = (nr - r) / d;
      c[0] += (b[0] - c[0]) * t, c[1] += (b[1] - c[1]) * t, c[2] += (b[2] - c[2]) * t;
      r = nr;
    }
  }
  s.x = (float)c[0], s.y = (float)c[1], s.z = (float)c[2];
  c[0] = s.x, c[1] = s.y, c[2] = s.z;
  for (i = 0; i < n; ++i) {
    double b[3], d;
    b[0] = spheres[i].x, b[1] = spheres[i].y, b[2] = spheres[i].z;
    d = vgeodag__distance(c, b) + spheres[i].r;
    if (d > need) need = d;
  }
  s.r = vgeodag__radius_up(need);
  return s;
}

int vgeodag_derive(vgeodag_mesh* m) {
  uint32_t c, g, i, n, max_level = 0;
  int have_leaf = 0;
  vgeodag_sphere* scratch;
  size_t scratch_n = 1;
  if (!m || (m->cluster_count && !m->clusters) || (m->group_count && !m->groups) ||
      (m->vertex_count && !m->positions) || (m->generated_count && !m->generated_clusters))
    return VGEODAG_ERROR_ARGUMENT;
  for (c = 0; c < m->cluster_count; ++c) {
    vgeodag_cluster* k = &m->clusters[c];
    if ((uint64_t)k->vertex_offset + k->vertex_count > m->vertex_count || k->group >= m->group_count)
      return VGEODAG_ERROR_ARGUMENT;
    k->bounds = vgeodag_enclose_points(m->positions + 3 * (size_t)k->vertex_offset, k->vertex_count);
    if (k->generating_group == VGEODAG_NONE) {
      uint32_t v;
      k->lod_bounds = k->bounds;
      k->lod_error = 0.0f;
      for (v = 0; v < k->vertex_count; ++v) {
        const float* p = m->positions + 3 * ((size_t)k->vertex_offset + v);
        int a;
        for (a = 0; a < 3; ++a) {
          if (!have_leaf || p[a] < m->bounds_min[a]) m->bounds_min[a] = p[a];
          if (!have_leaf || p[a] > m->bounds_max[a]) m->bounds_max[a] = p[a];
        }
        have_leaf = 1;
      }
    } else if (k->generating_group >= m->group_count) {
      return VGEODAG_ERROR_ARGUMENT;
    }
    if (k->level > max_level) max_level = k->level;
  }
  if (!have_leaf) memset(m->bounds_min, 0, sizeof m->bounds_min), memset(m->bounds_max, 0, sizeof m->bounds_max);
  m->level_count = m->cluster_count ? max_level + 1 : 0;
  for (g = 0; g < m->group_count; ++g) {
    const vgeodag_group* G = &m->groups[g];
    if ((uint64_t)G->first_cluster + G->cluster_count > m->cluster_count ||
        (uint64_t)G->first_generated + G->generated_count > m->generated_count)
      return VGEODAG_ERROR_ARGUMENT;
    if (G->cluster_count + 1 > scratch_n) scratch_n = G->cluster_count + 1;
    if (g && G->level < m->groups[g - 1].level) return VGEODAG_ERROR_ORDER;
  }
  scratch = (vgeodag_sphere*)malloc(scratch_n * sizeof *scratch);
  if (!scratch) return VGEODAG_ERROR_MEMORY;
  /* Groups in level order: a group's members' lod values were set by lower-level groups. */
  for (g = 0; g < m->group_count; ++g) {
    vgeodag_group* G = &m->groups[g];
    for (i = 0; i < G->cluster_count; ++i) {
      const vgeodag_cluster* k = &m->clusters[G->first_cluster + i];
      if (k->generating_group != VGEODAG_NONE && m->groups[k->generating_group].level >= G->level) {
        free(scratch);
        return VGEODAG_ERROR_ORDER;
      }
      scratch[i] = k->bounds;
    }
    G->bounds = vgeodag_enclose_spheres(scratch, G->cluster_count);
    /* The builder's own sphere first (present iff r > 0: zero-initialised means none): the
     * fold keeps it whole when it encloses the members, instead of growing a re-fold. */
    n = 0;
    if (G->builder_sphere.r > 0.0f) scratch[n++] = G->builder_sphere;
    for (i = 0; i < G->cluster_count; ++i) scratch[n++] = m->clusters[G->first_cluster + i].lod_bounds;
    G->parent_bounds = vgeodag_enclose_spheres(scratch, n);
    if (G->flags & VGEODAG_GROUP_TERMINAL) G->parent_error = VGEODAG_TERMINAL_ERROR;
    for (i = 0; i < G->cluster_count; ++i) {
      vgeodag_cluster* k = &m->clusters[G->first_cluster + i];
      k->parent_bounds = G->parent_bounds;
      k->parent_error = G->parent_error;
    }
    for (i = 0; i < G->generated_count; ++i) {
      uint32_t p = m->generated_clusters[G->first_generated + i];
      if (p >= m->cluster_count) {
        free(scratch);
        return VGEODAG_ERROR_ARGUMENT;
      }
      m->clusters[p].lod_bounds = G->parent_bounds;
      m->clusters[p].lod_error = G->parent_error;
    }
  }
  free(scratch);
  return VGEODAG_OK;
}

int vgeodag_derive_bvh(const vgeodag_mesh* m, vgeodag_bvh_node* nodes, uint32_t node_count) {
  /* Pre-order from the root, each node at most once; reverse pre-order visits children before
   * their parents. */
  uint32_t* order;
  unsigned char* seen;
  uint32_t head = 0, tail = 0, k;
  int rc = VGEODAG_OK;
  if (!m || !nodes || node_count == 0 || (m->group_count && !m->groups)) return VGEODAG_ERROR_ARGUMENT;
  order = (uint32_t*)malloc(node_count * sizeof *order);
  seen = (unsigned char*)calloc(node_count, 1);
  if (!order || !seen) {
    free(order), free(seen);
    return VGEODAG_ERROR_MEMORY;
  }
  order[tail++] = 0, seen[0] = 1;
  while (head < tail && rc == VGEODAG_OK) {
    const vgeodag_bvh_node* N = &nodes[order[head++]];
    if (N->child_count == 0 || N->child_count > VGEODAG_BVH_MAX_CHILDREN) rc = VGEODAG_ERROR_ARGUMENT;
    for (k = 0; rc == VGEODAG_OK && k < N->child_count; ++k) {
      uint32_t ch = N->children[k];
      if (N->group_mask & (1u << k)) {
        if (ch >= m->group_count) rc = VGEODAG_ERROR_ARGUMENT;
      } else if (ch >= node_count || seen[ch]) {
        rc = VGEODAG_ERROR_ARGUMENT;
      } else {
        seen[ch] = 1, order[tail++] = ch;
      }
    }
  }
  if (rc == VGEODAG_OK && tail != node_count) rc = VGEODAG_ERROR_ARGUMENT; /* a node not reached */
  while (rc == VGEODAG_OK && tail-- > 0) {
    vgeodag_bvh_node* N = &nodes[order[tail]];
    vgeodag_sphere b[VGEODAG_BVH_MAX_CHILDREN + 1], lb[VGEODAG_BVH_MAX_CHILDREN + 1];
    uint32_t nb = 0, nlb = 0;
    float e = 0.0f;
    if (N->bounds.r > 0.0f) b[nb++] = N->bounds;      /* your sphere first, as for builder_sphere */
    if (N->lod_bounds.r > 0.0f) lb[nlb++] = N->lod_bounds;
    for (k = 0; k < N->child_count; ++k) {
      uint32_t ch = N->children[k];
      float ce;
      if (N->group_mask & (1u << k)) {
        const vgeodag_group* G = &m->groups[ch];
        b[nb++] = G->bounds, lb[nlb++] = G->parent_bounds, ce = G->parent_error;
      } else {
        const vgeodag_bvh_node* C = &nodes[ch];
        b[nb++] = C->bounds, lb[nlb++] = C->lod_bounds, ce = C->max_parent_error;
      }
      if (!(ce <= e)) e = ce; /* NaN propagates: verify reports it */
    }
    for (k = N->child_count; k < VGEODAG_BVH_MAX_CHILDREN; ++k) N->children[k] = VGEODAG_NONE;
    N->group_mask &= (1u << N->child_count) - 1u;
    N->bounds = vgeodag_enclose_spheres(b, nb);
    N->lod_bounds = vgeodag_enclose_spheres(lb, nlb);
    N->max_parent_error = e;
  }
  free(order), free(seen);
  return rc;
}

/* ---- BVH8 over the groups, bottom-up: up to 8 consecutive groups per node, then up to 8
 * consecutive nodes per node, until one remains; stored root first (node 0). ---- */
typedef struct vgeodag__bvh {
  vgeodag_bvh_node* nodes;
  uint32_t count;
} vgeodag__bvh;

static int vgeodag__build_bvh(const vgeodag_mesh* m, vgeodag__bvh* out) {
  uint32_t total = 0, layer = m->group_count, layers = 0, l, base, prev_base = 0, prev_n = m->group_count;
  uint32_t layer_start[33];
  out->nodes = NULL;
  out->count = 0;
  if (m->group_count == 0) return VGEODAG_OK;
  /* Layer sizes from the bottom; node indices assigned top (root) first. */
  do {
    layer = (layer + VGEODAG_BVH_MAX_CHILDREN - 1) / VGEODAG_BVH_MAX_CHILDREN;
    layer_start[layers++] = layer; /* size for now */
    total += layer;
  } while (layer > 1);
  out->nodes = (vgeodag_bvh_node*)calloc(total, sizeof *out->nodes);
  if (!out->nodes) return VGEODAG_ERROR_MEMORY;
  out->count = total;
  {
    uint32_t sizes[33], start = 0;
    memcpy(sizes, layer_start, sizeof sizes);
    for (l = layers; l-- > 0;) layer_start[l] = start, start += sizes[l];
    for (l = 0; l < layers; ++l) {
      uint32_t n, n_nodes = sizes[l];
      base = layer_start[l];
      for (n = 0; n < n_nodes; ++n) {
        vgeodag_bvh_node* N = &out->nodes[base + n];
        vgeodag_sphere b[VGEODAG_BVH_MAX_CHILDREN], lb[VGEODAG_BVH_MAX_CHILDREN];
        uint32_t i;
        N->max_parent_error = 0.0f;
        for (i = 0; i < VGEODAG_BVH_MAX_CHILDREN; ++i) N->children[i] = VGEODAG_NONE;
        for (i = 0; i < VGEODAG_BVH_MAX_CHILDREN && n * VGEODAG_BVH_MAX_CHILDREN + i < prev_n; ++i) {
          uint32_t ch = n * VGEODAG_BVH_MAX_CHILDREN + i;
          float e;
          if (l == 0) {
            const vgeodag_group* G = &m->groups[ch];
            b[i] = G->bounds, lb[i] = G->parent_bounds, e = G->parent_error;
            N->group_mask |= 1u << i;
            N->children[i] = ch;
          } else {
            const vgeodag_bvh_node* C = &out->nodes[prev_base + ch];
            b[i] = C->bounds, lb[i] = C->lod_bounds, e = C->max_parent_error;
            N->children[i] = prev_base + ch;
          }
          if (!(e <= N->max_parent_error)) N->max_parent_error = e; /* NaN propagates: verify reports it */
        }
        N->child_count = i;
        N->bounds = vgeodag_enclose_spheres(b, i);
        N->lod_bounds = vgeodag_enclose_spheres(lb, i);
      }
      prev_base = base;
      prev_n = n_nodes;
    }
  }
  return VGEODAG_OK;
}

/* ---- little-endian byte output ---- */
typedef struct vgeodag__out {
  FILE* f;
  int failed;
} vgeodag__out;

static void vgeodag__bytes(vgeodag__out* o, const void* p, size_t n) {
  if (!o->failed && n && fwrite(p, 1, n, o->f) != n) o->failed = 1;
}
static void vgeodag__u32(vgeodag__out* o, uint32_t v) {
  unsigned char b[4];
  b[0] = (unsigned char)v, b[1] = (unsigned char)(v >> 8), b[2] = (unsigned char)(v >> 16),
  b[3] = (unsigned char)(v >> 24);
  vgeodag__bytes(o, b, 4);
}
static void vgeodag__f32(vgeodag__out* o, float f) {
  uint32_t u;
  memcpy(&u, &f, 4);
  vgeodag__u32(o, u);
}
static void vgeodag__sphere(vgeodag__out* o, vgeodag_sphere s) {
  vgeodag__f32(o, s.x), vgeodag__f32(o, s.y), vgeodag__f32(o, s.z), vgeodag__f32(o, s.r);
}

static int vgeodag__write_mesh(vgeodag__out* o, const vgeodag_mesh* m) {
  uint32_t i, flags = (m->normals ? VGEODAG_MESH_HAS_NORMALS : 0u) | (m->uvs ? VGEODAG_MESH_HAS_UVS : 0u);
  size_t j;
  vgeodag__bvh own = {NULL, 0};
  const vgeodag_bvh_node* nodes = m->bvh_nodes;
  uint32_t node_count = m->bvh_node_count;
  if ((m->cluster_count && !m->clusters) || (m->group_count && !m->groups) ||
      (m->generated_count && !m->generated_clusters) || (m->vertex_count && !m->positions) ||
      (m->triangle_count && !m->indices))
    return VGEODAG_ERROR_ARGUMENT;
  if (!nodes) {
    int rc = vgeodag__build_bvh(m, &own);
    if (rc) return rc;
    nodes = own.nodes, node_count = own.count;
  }
  vgeodag__u32(o, flags);
  vgeodag__u32(o, m->level_count);
  for (i = 0; i < 3; ++i) vgeodag__f32(o, m->bounds_min[i]);
  for (i = 0; i < 3; ++i) vgeodag__f32(o, m->bounds_max[i]);
  vgeodag__u32(o, m->cluster_count), vgeodag__u32(o, m->group_count), vgeodag__u32(o, m->generated_count);
  vgeodag__u32(o, node_count), vgeodag__u32(o, m->vertex_count), vgeodag__u32(o, m->triangle_count);
  for (i = 0; i < m->cluster_count; ++i) {
    const vgeodag_cluster* k = &m->clusters[i];
    vgeodag__u32(o, k->vertex_offset), vgeodag__u32(o, k->vertex_count);
    vgeodag__u32(o, k->triangle_offset), vgeodag__u32(o, k->triangle_count);
    vgeodag__u32(o, k->group), vgeodag__u32(o, k->generating_group), vgeodag__u32(o, k->level);
    vgeodag__u32(o, k->triangle_offset); /* material_offset == triangle_offset */
    vgeodag__sphere(o, k->bounds), vgeodag__sphere(o, k->lod_bounds), vgeodag__sphere(o, k->parent_bounds);
    vgeodag__f32(o, k->lod_error), vgeodag__f32(o, k->parent_error);
  }
  for (i = 0; i < m->group_count; ++i) {
    const vgeodag_group* G = &m->groups[i];
    vgeodag__u32(o, G->first_cluster), vgeodag__u32(o, G->cluster_count);
    vgeodag__u32(o, G->first_generated), vgeodag__u32(o, G->generated_count);
    vgeodag__u32(o, G->level), vgeodag__u32(o, G->flags);
    vgeodag__sphere(o, G->bounds), vgeodag__sphere(o, G->parent_bounds);
    vgeodag__f32(o, G->parent_error);
  }
  for (i = 0; i < m->generated_count; ++i) vgeodag__u32(o, m->generated_clusters[i]);
  for (i = 0; i < node_count; ++i) {
    const vgeodag_bvh_node* N = &nodes[i];
    uint32_t s;
    vgeodag__sphere(o, N->bounds), vgeodag__sphere(o, N->lod_bounds);
    vgeodag__f32(o, N->max_parent_error);
    vgeodag__u32(o, N->child_count), vgeodag__u32(o, N->group_mask);
    for (s = 0; s < VGEODAG_BVH_MAX_CHILDREN; ++s) vgeodag__u32(o, N->children[s]);
  }
  free(own.nodes);
  for (j = 0; j < 3 * (size_t)m->vertex_count; ++j) vgeodag__f32(o, m->positions[j]);
  if (m->normals)
    for (j = 0; j < 3 * (size_t)m->vertex_count; ++j) vgeodag__f32(o, m->normals[j]);
  if (m->uvs)
    for (j = 0; j < 2 * (size_t)m->vertex_count; ++j) vgeodag__f32(o, m->uvs[j]);
  vgeodag__bytes(o, m->indices, 3 * (size_t)m->triangle_count);
  for (j = 0; j < m->triangle_count; ++j) vgeodag__u32(o, m->triangle_materials ? m->triangle_materials[j] : 0u);
  return VGEODAG_OK;
}

int vgeodag_write_file(const char* path, const vgeodag_scene* scene) {
  static const char kMagic[8] = {'V', 'G', 'E', 'O', 'D', 'A', 'G', '1'};
  vgeodag__out o;
  char* tmp;
  size_t len;
  uint32_t i;
  int rc = VGEODAG_OK;
  if (!path || !scene || (scene->mesh_count && !scene->meshes) || (scene->material_count && !scene->materials) ||
      (scene->instance_count && !scene->instances))
    return VGEODAG_ERROR_ARGUMENT;
  len = strlen(path);
  tmp = (char*)malloc(len + 5);
  if (!tmp) return VGEODAG_ERROR_MEMORY;
  memcpy(tmp, path, len);
  memcpy(tmp + len, ".tmp", 5);
  o.f = fopen(tmp, "wb");
  o.failed = 0;
  if (!o.f) {
    free(tmp);
    return VGEODAG_ERROR_IO;
  }
  vgeodag__bytes(&o, kMagic, 8);
  vgeodag__u32(&o, 1); /* version */
  vgeodag__u32(&o, scene->mesh_count), vgeodag__u32(&o, scene->material_count), vgeodag__u32(&o, scene->instance_count);
  for (i = 0; i < scene->material_count; ++i) {
    const vgeodag_material* mat = &scene->materials[i];
    size_t n = mat->name ? strlen(mat->name) : 0;
    int c;
    vgeodag__u32(&o, (uint32_t)n);
    vgeodag__bytes(&o, mat->name, n);
    for (c = 0; c < 4; ++c) vgeodag__f32(&o, mat->base_color[c]);
  }
  for (i = 0; i < scene->instance_count; ++i) {
    int c;
    vgeodag__u32(&o, scene->instances[i].mesh);
    for (c = 0; c < 16; ++c) vgeodag__f32(&o, scene->instances[i].transform[c]);
  }
  for (i = 0; i < scene->mesh_count && rc == VGEODAG_OK; ++i) rc = vgeodag__write_mesh(&o, &scene->meshes[i]);
  if (fclose(o.f) != 0) o.failed = 1;
  if (rc == VGEODAG_OK && o.failed) rc = VGEODAG_ERROR_IO;
  if (rc == VGEODAG_OK && rename(tmp, path) != 0) rc = VGEODAG_ERROR_IO;
  if (rc != VGEODAG_OK) remove(tmp);
  free(tmp);
  return rc;
}

#endif /* VGEODAG_WRITER_IMPLEMENTED */
#endif /* VGEODAG_WRITER_IMPLEMENTATION */

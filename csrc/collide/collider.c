// Colliders as signed distances: plane, box, sphere, capsule, closed and open triangle meshes, static, moving
// or deforming. Shared by the subsystems that collide (MPM and the ARAP solver), one implementation of each.
//
// Design: every shape is a signed distance φ (negative inside) with an outward normal, evaluated in the
// collider's frame. A moving collider goes from its frame at the start of a call to the target set by
// od_Collider_SetTarget, linearly in translation and along the shortest arc in rotation, so it has one
// linear and one angular velocity per call; od_Collider_Place puts it at a fraction of the call.
// A mesh is turned once into distance samples on a local grid: exact distances to the triangles in a
// narrow band, a chamfer sweep beyond it, and the sign from the parity of ray crossings along x. An open mesh
// (a ramp, a terrain, a table top: no inside to count crossings into) takes its sign from the side of its
// nearest triangle instead, carried through the sweep with the distance: inside is what lies behind its faces,
// not what lies beyond its rim (the edges of one triangle), where the side extended until 2026-11-27 and a body
// that slid off a ramp was inside at any depth behind it and flung up; and only a slab OD_OPEN_DEPTH samples deep
// behind them, its back a face too, so that a body under a table top is outside and meets its underside (at any
// depth, it was pushed through to the top). New vertices (a deforming collider) are sampled into new memory that
// replaces the old only once complete, so that a call stopped part-way (od_CheckInterrupt: Ctrl-C, polled
// every 64 triangles and every plane of samples) or out of memory leaves the collider as it was. Cost: about
// 8 us a triangle at resolution 64 (a 998,000-triangle sphere: 8.3 s to add, 7.8 s a vertex update, one core
// of this machine), from the exact distances in the band around each triangle.
// What a contact does (stick, slip, push back) is the caller's: see mpm/collider.c.
#include "collider.h"

#include "core.h"
#include "interrupt.h"
#include "sort.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#define OD_MESH_MAX_DIM 96 // distance samples per axis at most
#define OD_MESH_BAND 3     // samples around each triangle that get the exact distance
#define OD_MESH_POLL 63    // triangles between interrupt checks, less one (a power of two less one)
// How deep behind its faces an open mesh is inside, in samples: less than the sample box's margin (OD_MESH_BAND +
// 1), so that every sample on the box's faces is outside and so is all beyond it.
#define OD_OPEN_DEPTH 3.5

// ---------------------------------------------------------------------------------------------------------
// Mesh distance samples

// A triangle's features, as bits of od_RimFeatures' masks: its corners a, b, c and its edges ab, bc, ca.
enum
{
	OD_AT_A,
	OD_AT_B,
	OD_AT_C,
	OD_ON_AB,
	OD_ON_BC,
	OD_ON_CA,
	OD_WITHIN
};

// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5), and in *feature the corner
// or edge it lies on (OD_WITHIN: inside the triangle).
static od_Vec3 od_ClosestOnTriangle(od_Vec3 p, od_Vec3 a, od_Vec3 b, od_Vec3 c, int* feature)
{
	od_Vec3 ab = od_Sub(b, a), ac = od_Sub(c, a), ap = od_Sub(p, a);
	double d1 = od_Dot(ab, ap), d2 = od_Dot(ac, ap);
	if (d1 <= 0.0 && d2 <= 0.0)
	{
		*feature = OD_AT_A;
		return a;
	}
	od_Vec3 bp = od_Sub(p, b);
	double d3 = od_Dot(ab, bp), d4 = od_Dot(ac, bp);
	if (d3 >= 0.0 && d4 <= d3)
	{
		*feature = OD_AT_B;
		return b;
	}
	double vc = d1 * d4 - d3 * d2;
	if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0)
	{
		*feature = OD_ON_AB;
		return od_MulAdd(a, d1 / (d1 - d3), ab);
	}
	od_Vec3 cp = od_Sub(p, c);
	double d5 = od_Dot(ab, cp), d6 = od_Dot(ac, cp);
	if (d6 >= 0.0 && d5 <= d6)
	{
		*feature = OD_AT_C;
		return c;
	}
	double vb = d5 * d2 - d1 * d6;
	if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0)
	{
		*feature = OD_ON_CA;
		return od_MulAdd(a, d2 / (d2 - d6), ac);
	}
	double va = d3 * d6 - d5 * d4;
	if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0)
	{
		*feature = OD_ON_BC;
		return od_MulAdd(b, (d4 - d3) / ((d4 - d3) + (d5 - d6)), od_Sub(c, b));
	}
	double denom = 1.0 / (va + vb + vc);
	*feature = OD_WITHIN;
	return od_Add(a, od_Add(od_Scale(vb * denom, ab), od_Scale(vc * denom, ac)));
}

static int od_CompareDouble(const void* a, const void* b)
{
	double x = *(const double*)a, y = *(const double*)b;
	return (x > y) - (x < y);
}

typedef struct od_MeshView
{
	const double* v;
	const int* t;
	int triangles;
	const unsigned char* rim; // an open mesh's: per triangle, its features on the rim (od_RimFeatures)
} od_MeshView;

static od_Vec3 od_MeshVertex(const od_MeshView* m, int tri, int corner)
{
	return od_V3Load(m->v + 3 * m->t[3 * tri + corner]);
}

static size_t od_SdfIndex(const int dims[3], int i, int j, int k)
{
	return ((size_t)k * dims[1] + j) * dims[0] + i;
}

// An open mesh's sample at index `at` keeps the nearest triangle's distance d and the cosine between the
// direction to the sample and that triangle's normal; of triangles equally near (an edge or a vertex), the one
// that faces the sample most squarely, which is the side that a fold's either face agrees on.
static void od_KeepSide(od_Collider* c, size_t at, double d, double cosine)
{
	double tie = 1e-9 * c->spacing;
	if (d < c->sdf[at] - tie || (d <= c->sdf[at] + tie && fabs(cosine) > fabs(c->side[at])))
	{
		c->sdf[at] = fmin(c->sdf[at], d);
		c->side[at] = cosine;
	}
}

// Exact unsigned distances within OD_MESH_BAND samples of each triangle (and an open mesh's sides).
static od_Status od_SdfBand(od_Collider* c, const od_MeshView* m)
{
	for (int tri = 0; tri < m->triangles; ++tri)
	{
		od_Status status = (tri & OD_MESH_POLL) == 0 ? od_CheckInterrupt() : OD_OK;
		if (status != OD_OK)
		{
			return status;
		}
		od_Vec3 a = od_MeshVertex(m, tri, 0), b = od_MeshVertex(m, tri, 1), cc = od_MeshVertex(m, tri, 2);
		od_Vec3 normal = od_Cross(od_Sub(b, a), od_Sub(cc, a));
		double area = od_Length(normal);
		normal = area > 0.0 ? od_Scale(1.0 / area, normal) : normal;
		int lo[3], hi[3];
		double va[3], vb[3], vc[3]; // by index: (&a.x)[1] reads past a.x, which clang's optimizer exploited
		od_V3Store(va, a);
		od_V3Store(vb, b);
		od_V3Store(vc, cc);
		for (int ax = 0; ax < 3; ++ax)
		{
			double mn = fmin(fmin(va[ax], vb[ax]), vc[ax]);
			double mx = fmax(fmax(va[ax], vb[ax]), vc[ax]);
			lo[ax] = (int)floor((mn - c->origin[ax]) / c->spacing) - OD_MESH_BAND;
			hi[ax] = (int)ceil((mx - c->origin[ax]) / c->spacing) + OD_MESH_BAND;
			lo[ax] = lo[ax] < 0 ? 0 : lo[ax];
			hi[ax] = hi[ax] >= c->dims[ax] ? c->dims[ax] - 1 : hi[ax];
		}
		for (int k = lo[2]; k <= hi[2]; ++k)
		{
			for (int j = lo[1]; j <= hi[1]; ++j)
			{
				for (int i = lo[0]; i <= hi[0]; ++i)
				{
					od_Vec3 p = od_V3(c->origin[0] + i * c->spacing, c->origin[1] + j * c->spacing,
									  c->origin[2] + k * c->spacing);
					int feature;
					od_Vec3 q = od_ClosestOnTriangle(p, a, b, cc, &feature);
					double d = od_Length(od_Sub(p, q));
					size_t at = od_SdfIndex(c->dims, i, j, k);
					if (c->side)
					{
						// beyond the rim is outside, on either side of the faces' plane
						double cosine = d > 0.0 ? od_Dot(od_Sub(p, q), normal) / d : 0.0;
						bool rim = feature != OD_WITHIN && (m->rim[tri] >> feature & 1);
						od_KeepSide(c, at, d, rim ? fabs(cosine) : cosine);
					}
					else
					{
						c->sdf[at] = fmin(c->sdf[at], d);
					}
				}
			}
		}
	}
	return OD_OK;
}

// Two chamfer sweeps (26 neighbours) carry the band's distances (and an open mesh's sides) through the rest of
// the samples.
static od_Status od_SdfSweep(od_Collider* c)
{
	const int* n = c->dims;
	double reach[4]; // the distance to a neighbour by its squared offset in samples
	for (int d2 = 0; d2 < 4; ++d2)
	{
		reach[d2] = c->spacing * sqrt((double)d2);
	}
	// An open mesh's samples keep their side against a neighbour's distance equal to theirs but for rounding
	// (a sample on a face, its side undefined, made the next row behind the face outside: a sheet 0.6 m wide at
	// resolution 64 read 7 mm behind its faces as 7 mm in front).
	double tie = 1e-9 * c->spacing;
	for (int pass = 0; pass < 2; ++pass)
	{
		int step = pass == 0 ? 1 : -1;
		for (int kk = 0; kk < n[2]; ++kk)
		{
			if (od_CheckInterrupt() != OD_OK)
			{
				return OD_ERROR_INTERRUPTED;
			}
			int k = pass == 0 ? kk : n[2] - 1 - kk;
			for (int jj = 0; jj < n[1]; ++jj)
			{
				int j = pass == 0 ? jj : n[1] - 1 - jj;
				for (int ii = 0; ii < n[0]; ++ii)
				{
					int i = pass == 0 ? ii : n[0] - 1 - ii;
					double* s = &c->sdf[od_SdfIndex(n, i, j, k)];
					// neighbours already visited in this sweep direction
					for (int dz = -1; dz <= 0; ++dz)
					{
						for (int dy = -1; dy <= 1; ++dy)
						{
							for (int dxx = -1; dxx <= 1; ++dxx)
							{
								if (dz == 0 && (dy > 0 || (dy == 0 && dxx >= 0)))
								{
									continue;
								}
								int a = i + step * dxx, b = j + step * dy, e = k + step * dz;
								if (a < 0 || b < 0 || e < 0 || a >= n[0] || b >= n[1] || e >= n[2])
								{
									continue;
								}
								size_t from = od_SdfIndex(n, a, b, e);
								double through = c->sdf[from] + reach[dxx * dxx + dy * dy + dz * dz];
								if (through < *s)
								{
									if (c->side && through < *s - tie)
									{
										c->side[s - c->sdf] = c->side[from];
									}
									*s = through;
								}
							}
						}
					}
				}
			}
		}
	}
	return OD_OK;
}

// The rows of samples (j, k) whose yz lies in triangle tri's yz bounds: [lo[0], hi[0]] x [lo[1], hi[1]].
static void od_RowRange(const od_Collider* c, const od_MeshView* m, int tri, int lo[2], int hi[2])
{
	for (int a = 0; a < 2; ++a)
	{
		double mn = INFINITY, mx = -INFINITY;
		for (int corner = 0; corner < 3; ++corner)
		{
			double v = m->v[3 * m->t[3 * tri + corner] + 1 + a];
			mn = fmin(mn, v);
			mx = fmax(mx, v);
		}
		lo[a] = (int)fmax(floor((mn - c->origin[1 + a]) / c->spacing), 0.0);
		hi[a] = (int)fmin(ceil((mx - c->origin[1 + a]) / c->spacing), c->dims[1 + a] - 1.0);
	}
}

// Counts (fill = NULL) or lists (fill: each row's next free slot) the triangles of each row of samples.
static void od_VisitRows(const od_Collider* c, const od_MeshView* m, int* count, int* fill, int* rowTris)
{
	for (int tri = 0; tri < m->triangles; ++tri)
	{
		int lo[2], hi[2];
		od_RowRange(c, m, tri, lo, hi);
		for (int k = lo[1]; k <= hi[1]; ++k)
		{
			for (int j = lo[0]; j <= hi[0]; ++j)
			{
				size_t row = (size_t)k * c->dims[1] + j;
				if (fill)
				{
					rowTris[fill[row]++] = tri;
				}
				else
				{
					++count[row + 1];
				}
			}
		}
	}
}

// Per row of samples along x, the triangles whose yz bounds hold it (rows rowStart[r]..rowStart[r+1] of
// rowTris): what its ray can cross. Measured: a 3,744-triangle sphere sampled at 64 took 185 ms when every
// row tested every triangle.
static int* od_RowTriangles(const od_Collider* c, const od_MeshView* m, int** rowTris)
{
	size_t rows = (size_t)c->dims[1] * c->dims[2];
	int* start = od_AllocZero(rows + 1, sizeof(int));
	int* fill = od_Alloc(sizeof(int) * (rows + 1));
	if (start && fill)
	{
		od_VisitRows(c, m, start, NULL, NULL);
		for (size_t r = 0; r < rows; ++r)
		{
			start[r + 1] += start[r];
		}
		memcpy(fill, start, sizeof(int) * (rows + 1));
		*rowTris = od_Alloc(sizeof(int) * ((size_t)start[rows] + 1));
	}
	if (*rowTris)
	{
		od_VisitRows(c, m, NULL, fill, *rowTris);
	}
	od_Free(fill);
	return start;
}

// Negates the samples inside the mesh: odd number of crossings of the +x ray from each sample.
static od_Status od_SdfSign(od_Collider* c, const od_MeshView* m)
{
	int* rowTris = NULL;
	int* rowStart = od_RowTriangles(c, m, &rowTris);
	double* hits = od_Alloc(sizeof(double) * (size_t)m->triangles);
	if (!hits || !rowStart || !rowTris)
	{
		od_Free(hits);
		od_Free(rowStart);
		od_Free(rowTris);
		return od_Fail(OD_ERROR_MEMORY, "collider: out of memory");
	}
	// a tiny irrational offset keeps rays off shared edges and vertices
	const double jitter[2] = { 1.37e-7 * c->spacing, 2.71e-7 * c->spacing };
	od_Status status = OD_OK;
	for (int k = 0; k < c->dims[2] && status == OD_OK; ++k)
	{
		status = od_CheckInterrupt();
		for (int j = 0; j < c->dims[1] && status == OD_OK; ++j)
		{
			double y = c->origin[1] + j * c->spacing + jitter[0], z = c->origin[2] + k * c->spacing + jitter[1];
			int count = 0;
			size_t row = (size_t)k * c->dims[1] + j;
			for (int r = rowStart[row]; r < rowStart[row + 1]; ++r)
			{
				int tri = rowTris[r];
				od_Vec3 a = od_MeshVertex(m, tri, 0), b = od_MeshVertex(m, tri, 1), e = od_MeshVertex(m, tri, 2);
				// barycentric coordinates of (y, z) in the triangle projected on the yz plane
				double det = (b.y - a.y) * (e.z - a.z) - (e.y - a.y) * (b.z - a.z);
				if (det == 0.0)
				{
					continue;
				}
				double u = ((y - a.y) * (e.z - a.z) - (e.y - a.y) * (z - a.z)) / det;
				double v = ((b.y - a.y) * (z - a.z) - (y - a.y) * (b.z - a.z)) / det;
				if (u >= 0.0 && v >= 0.0 && u + v <= 1.0)
				{
					hits[count++] = a.x + u * (b.x - a.x) + v * (e.x - a.x);
				}
			}
			qsort(hits, (size_t)count, sizeof *hits, od_CompareDouble);
			int h = 0;
			for (int i = 0; i < c->dims[0]; ++i)
			{
				double x = c->origin[0] + i * c->spacing;
				while (h < count && hits[h] < x)
				{
					++h;
				}
				if (h % 2 == 1)
				{
					double* s = &c->sdf[od_SdfIndex(c->dims, i, j, k)];
					*s = -*s;
				}
			}
		}
	}
	od_Free(hits);
	od_Free(rowStart);
	od_Free(rowTris);
	return status;
}

// Makes an open mesh's samples behind their nearest triangle a slab OD_OPEN_DEPTH samples deep: negative within
// it, by their distance to its nearer side (the faces or the slab's back), positive beyond it.
static void od_SdfSide(od_Collider* c, size_t total)
{
	double depth = OD_OPEN_DEPTH * c->spacing;
	for (size_t i = 0; i < total; ++i)
	{
		double d = c->sdf[i];
		c->sdf[i] = !(c->side[i] < 0.0) ? d : d <= 0.5 * depth ? -d : d - depth;
	}
}

// Checks a mesh's vertices (finite) and triangles (in range); its bounds, and its radius about the frame origin.
static od_Status od_MeshBounds(od_Collider* c, const od_MeshView* m, int vertexCount, double lo[3], double hi[3])
{
	c->radius = 0.0;
	for (int i = 0; i < vertexCount; ++i)
	{
		if (!od_IsFinite3(m->v + 3 * i))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "collider: vertices[%d] is not finite", i);
		}
		for (int a = 0; a < 3; ++a)
		{
			lo[a] = fmin(lo[a], m->v[3 * i + a]);
			hi[a] = fmax(hi[a], m->v[3 * i + a]);
		}
		c->radius = fmax(c->radius, od_Length(od_V3Load(m->v + 3 * i)));
	}
	for (int k = 0; k < 3 * m->triangles; ++k)
	{
		if (m->t[k] < 0 || m->t[k] >= vertexCount)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "collider: triangles[%d] uses vertex %d, outside [0, %d)", k / 3,
						   m->t[k], vertexCount);
		}
	}
	return OD_OK;
}

typedef struct od_Edge
{
	int a, b; // a < b
	int forward; // whether the triangle runs a -> b
	int triangle;
	int corner; // the edge runs from the triangle's corner `corner` to the next
} od_Edge;

static int od_CompareEdge(const void* x, const void* y)
{
	const od_Edge *p = x, *q = y;
	return p->a != q->a ? (p->a > q->a) - (p->a < q->a) : (p->b > q->b) - (p->b < q->b);
}

// The mesh's edges, three a triangle, sorted by their ends (ties in input order), into *out (freed by the caller).
static od_Status od_SortedEdges(const int* triangles, int triangleCount, od_Edge** out)
{
	od_Edge* e = *out = od_Alloc(sizeof(od_Edge) * 3 * (size_t)triangleCount);
	if (!e)
	{
		return od_Fail(OD_ERROR_MEMORY, "collider: out of memory");
	}
	for (int k = 0; k < 3 * triangleCount; ++k)
	{
		int from = triangles[k], to = triangles[k % 3 == 2 ? k - 2 : k + 1];
		e[k] = (od_Edge){ .a = from < to ? from : to, .b = from < to ? to : from, .forward = from < to, .triangle = k / 3,
						  .corner = k % 3 };
	}
	return od_Sort(e, 3 * (size_t)triangleCount, sizeof *e, od_CompareEdge); // stable: ties in input order
}

// Per triangle, which of its features lie on an open mesh's rim (an edge of one triangle, or a corner at the end
// of one), into *out (freed by the caller): bit OD_ON_AB + k for its edge from corner k, bit k for corner k.
static od_Status od_RimFeatures(const int* triangles, int triangleCount, int vertexCount, unsigned char** out)
{
	od_Edge* e;
	od_Status status = od_SortedEdges(triangles, triangleCount, &e);
	unsigned char* rim = *out = od_AllocZero((size_t)triangleCount, 1);
	bool* onRim = od_AllocZero((size_t)vertexCount, sizeof(bool));
	status = status == OD_OK && !(rim && onRim) ? od_Fail(OD_ERROR_MEMORY, "collider: out of memory") : status;
	for (int k = 0, next; status == OD_OK && k < 3 * triangleCount; k = next)
	{
		for (next = k + 1; next < 3 * triangleCount && od_CompareEdge(&e[k], &e[next]) == 0; ++next)
		{
		}
		if (next - k == 1)
		{
			rim[e[k].triangle] |= (unsigned char)(1 << (OD_ON_AB + e[k].corner));
			onRim[e[k].a] = onRim[e[k].b] = true;
		}
	}
	for (int t = 0; status == OD_OK && t < triangleCount; ++t)
	{
		for (int corner = 0; corner < 3; ++corner)
		{
			rim[t] |= (unsigned char)(onRim[triangles[3 * t + corner]] << corner);
		}
	}
	od_Free(e);
	od_Free(onRim);
	return status;
}

// Distance samples of a mesh at the finest spacing its bounds allow (not finer than minSpacing), into c's
// memory when it is large enough.
static od_Status od_MeshSample(od_Collider* c, const od_MeshView* m, int vertexCount)
{
	double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
	od_Status status = od_MeshBounds(c, m, vertexCount, lo, hi);
	if (status != OD_OK)
	{
		return status;
	}
	double extent = fmax(fmax(hi[0] - lo[0], hi[1] - lo[1]), hi[2] - lo[2]);
	if (!(extent < 1e150)) // finite vertices whose differences overflow: no sample spacing fits them
	{
		return od_Fail(OD_ERROR_ARGUMENT, "collider: the mesh spans %g, too large a range", extent);
	}
	if (!(extent > 0.0)) // every vertex at one point: no spacing, the sampling grid's size was NaN
	{
		return od_Fail(OD_ERROR_ARGUMENT, "collider: the mesh has no extent (all its vertices at one point)");
	}
	c->spacing = fmax(c->minSpacing, extent / (OD_MESH_MAX_DIM - 2 * OD_MESH_BAND - 2));
	c->spacing = c->resolution > 0 ? fmax(c->spacing, extent / c->resolution) : c->spacing;
	size_t total = 1;
	for (int a = 0; a < 3; ++a)
	{
		c->origin[a] = lo[a] - (OD_MESH_BAND + 1) * c->spacing;
		c->dims[a] = (int)ceil((hi[a] - lo[a]) / c->spacing) + 2 * OD_MESH_BAND + 3;
		total *= (size_t)c->dims[a];
	}
	if (total > c->capacity)
	{
		bool open = c->kind == OD_SHAPE_OPEN_MESH;
		od_Free(c->sdf);
		od_Free(c->side);
		c->sdf = od_Alloc(total * sizeof(double));
		c->side = open ? od_Alloc(total * sizeof(double)) : NULL;
		c->capacity = c->sdf && (c->side || !open) ? total : 0;
		if (!c->capacity)
		{
			return od_Fail(OD_ERROR_MEMORY, "collider: out of memory");
		}
	}
	for (size_t i = 0; i < total; ++i)
	{
		c->sdf[i] = INFINITY;
	}
	if (c->side)
	{
		memset(c->side, 0, total * sizeof(double));
	}
	unsigned char* rim = NULL; // an open mesh's features on its rim
	status = c->side ? od_RimFeatures(m->t, m->triangles, vertexCount, &rim) : OD_OK;
	od_MeshView view = { m->v, m->t, m->triangles, rim };
	status = status == OD_OK ? od_SdfBand(c, &view) : status;
	od_Free(rim);
	status = status == OD_OK ? od_SdfSweep(c) : status;
	if (status != OD_OK || !c->side)
	{
		return status == OD_OK ? od_SdfSign(c, m) : status;
	}
	od_SdfSide(c, total);
	return OD_OK;
}

// od_MeshSample into new memory, which replaces c's only when sampling completes: a failure (an interrupt,
// out of memory) leaves c as it was.
static od_Status od_MeshResample(od_Collider* c, const od_MeshView* m, int vertexCount)
{
	od_Collider next = *c;
	next.sdf = next.side = NULL;
	next.capacity = 0;
	od_Status status = od_MeshSample(&next, m, vertexCount);
	if (status != OD_OK)
	{
		od_Collider_Destroy(&next);
		return status;
	}
	od_Collider_Destroy(c);
	*c = next;
	return OD_OK;
}

od_Status od_Collider_MeshTopology(const int* triangles, int triangleCount, bool* closed, int* flipped)
{
	od_Edge* e;
	od_Status status = od_SortedEdges(triangles, triangleCount, &e);
	*closed = true;
	*flipped = -1;
	for (int k = 0, next; status == OD_OK && k < 3 * triangleCount; k = next)
	{
		for (next = k + 1; next < 3 * triangleCount && od_CompareEdge(&e[k], &e[next]) == 0; ++next)
		{
			if (e[next].forward == e[k].forward && *flipped < 0)
			{
				*flipped = e[next].triangle > e[k].triangle ? e[next].triangle : e[k].triangle;
			}
		}
		*closed = *closed && next - k == 2;
	}
	od_Free(e);
	return status;
}

// A mesh declared open, or found open when asked to look (def->detectOpen), must be wound one way: the side
// of a triangle is what tells inside from outside.
static od_Status od_CheckOpen(od_Collider* c, const od_ShapeDef* def)
{
	bool closed;
	int flipped;
	od_Status status = od_Collider_MeshTopology(def->triangles, def->triangleCount, &closed, &flipped);
	c->kind = def->kind == OD_SHAPE_OPEN_MESH || !closed ? OD_SHAPE_OPEN_MESH : OD_SHAPE_MESH;
	if (status == OD_OK && c->kind == OD_SHAPE_OPEN_MESH && flipped >= 0)
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "collider: triangles[%d] is wound against a neighbour (an inverted face of an open mesh)",
					   flipped);
	}
	return status;
}

static od_Status od_MeshInit(od_Collider* c, const od_ShapeDef* def)
{
	if (def->triangleCount < 1 || def->vertexCount < 3 || !def->vertices || !def->triangles)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "collider: a mesh needs vertices and at least one triangle (got %d)",
					   def->triangleCount);
	}
	od_MeshView m = { def->vertices, def->triangles, def->triangleCount };
	c->minSpacing = def->spacing;
	c->resolution = def->resolution;
	od_Status status = od_MeshBounds(c, &m, def->vertexCount, (double[3]){ INFINITY, INFINITY, INFINITY },
									 (double[3]){ -INFINITY, -INFINITY, -INFINITY });
	if (status == OD_OK && (def->kind == OD_SHAPE_OPEN_MESH || def->detectOpen))
	{
		status = od_CheckOpen(c, def);
	}
	return status == OD_OK ? od_MeshResample(c, &m, def->vertexCount) : status;
}

od_Status od_Collider_SetVertices(od_Collider* c, const double* vertices, int vertexCount, const int* triangles,
								  int triangleCount)
{
	od_MeshView m = { vertices, triangles, triangleCount };
	double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
	double radius = c->radius;
	od_Status status = od_MeshBounds(c, &m, vertexCount, lo, hi); // checked first: a failure changes nothing
	c->radius = radius;
	return status == OD_OK ? od_MeshResample(c, &m, vertexCount) : status;
}

// The sample cell of local point p clamped into the sample box: its first sample i and fractions f; returns the
// squared distance beyond the box, in samples (0 inside it).
static double od_MeshCell(const od_Collider* c, od_Vec3 p, int i[3], double f[3])
{
	double g[3] = { (p.x - c->origin[0]) / c->spacing, (p.y - c->origin[1]) / c->spacing,
					(p.z - c->origin[2]) / c->spacing };
	double outside = 0.0;
	for (int a = 0; a < 3; ++a)
	{
		double lim = c->dims[a] - 1.000001;
		double clamped = g[a] > 0.0 ? (g[a] > lim ? lim : g[a]) : 0.0; // NaN: 0, a cell in the box (the distance NaN)
		outside += (g[a] - clamped) * (g[a] - clamped);
		i[a] = (int)clamped;
		f[a] = clamped - i[a];
	}
	return outside;
}

// The cell's 8 samples into v (corner bit 0: +x, 1: +y, 2: +z) and their trilinear blend at f.
static double od_CellBlend(const od_Collider* c, const int i[3], const double f[3], double v[8])
{
	double d = 0.0;
	for (int corner = 0; corner < 8; ++corner)
	{
		int a = corner & 1, b = (corner >> 1) & 1, e = corner >> 2;
		double w = (a ? f[0] : 1 - f[0]) * (b ? f[1] : 1 - f[1]) * (e ? f[2] : 1 - f[2]);
		v[corner] = c->sdf[od_SdfIndex(c->dims, i[0] + a, i[1] + b, i[2] + e)];
		d += w * v[corner];
	}
	return d;
}

// Trilinear sample of the mesh distance at local point p (clamped to the sample box, then the distance to it:
// beyond the box is outside a closed mesh and, behind an open one, inside).
static double od_MeshDistance(const od_Collider* c, od_Vec3 p)
{
	int i[3];
	double f[3], v[8];
	double outside = od_MeshCell(c, p, i, f), d = od_CellBlend(c, i, f, v);
	if (outside == 0.0)
	{
		return d + 0.0; // inside the sample box (+ 0.0: as below, -0.0 made +0.0)
	}
	return d < 0.0 ? d - sqrt(outside) * c->spacing : d + sqrt(outside) * c->spacing; // < 0: behind an open mesh
}

// The trilinear sample at local point p inside the sample box and its exact gradient (the cell's own), from
// the cell's 8 samples: one pass where central differences took seven samples (13.6 % of a 1,000-particle
// frame sliding down a ramp, measured). False beyond the box, where the distance to it is added.
static bool od_MeshGradient(const od_Collider* c, od_Vec3 p, double* d, od_Vec3* grad)
{
	int i[3];
	double f[3], v[8];
	if (!(od_MeshCell(c, p, i, f) == 0.0))
	{
		return false;
	}
	*d = od_CellBlend(c, i, f, v);
	double dx = 0.0, dy = 0.0, dz = 0.0;
	for (int k = 0; k < 4; ++k) // the 4 cell edges along each axis, weighted by the other two fractions
	{
		int b = k & 1, e = k >> 1;
		dx += (b ? f[1] : 1 - f[1]) * (e ? f[2] : 1 - f[2]) * (v[1 | b << 1 | e << 2] - v[b << 1 | e << 2]);
		dy += (b ? f[0] : 1 - f[0]) * (e ? f[2] : 1 - f[2]) * (v[b | 2 | e << 2] - v[b | e << 2]);
		dz += (b ? f[0] : 1 - f[0]) * (e ? f[1] : 1 - f[1]) * (v[b | e << 1 | 4] - v[b | e << 1]);
	}
	*grad = od_V3(dx, dy, dz);
	return true;
}

// ---------------------------------------------------------------------------------------------------------
// Shapes

// Signed distance and outward normal in the collider's frame (a mesh's normal outside only when `outside`).
static double od_ShapeDistance(const od_Collider* c, od_Vec3 p, od_Vec3* n, bool outside)
{
	const double* h = c->halfExtents;
	switch (c->kind)
	{
		case OD_SHAPE_PLANE:
			*n = od_V3(0, 0, 1);
			return p.z;
		case OD_SHAPE_SPHERE:
		{
			double len = od_Length(p);
			*n = len > 0.0 ? od_Scale(1.0 / len, p) : od_V3(0, 0, 1);
			return len - h[0];
		}
		case OD_SHAPE_BOX:
		{
			double q[3] = { fabs(p.x) - h[0], fabs(p.y) - h[1], fabs(p.z) - h[2] }, sgn[3] = { p.x < 0 ? -1 : 1,
																							  p.y < 0 ? -1 : 1,
																							  p.z < 0 ? -1 : 1 };
			if (q[0] > 0.0 || q[1] > 0.0 || q[2] > 0.0)
			{
				od_Vec3 o = od_V3(sgn[0] * fmax(q[0], 0.0), sgn[1] * fmax(q[1], 0.0), sgn[2] * fmax(q[2], 0.0));
				double len = od_Length(o);
				*n = od_Scale(1.0 / len, o);
				return len;
			}
			int a = q[0] >= q[1] && q[0] >= q[2] ? 0 : (q[1] >= q[2] ? 1 : 2);
			double nn[3] = { 0, 0, 0 };
			nn[a] = sgn[a];
			*n = od_V3Load(nn);
			return q[a];
		}
		case OD_SHAPE_CAPSULE:
		{
			od_Vec3 q = od_V3(p.x, p.y, p.z - fmax(-h[2], fmin(h[2], p.z)));
			double len = od_Length(q);
			*n = len > 0.0 ? od_Scale(1.0 / len, q) : od_V3(1, 0, 0);
			return len - h[0];
		}
		case OD_SHAPE_MESH:
		case OD_SHAPE_OPEN_MESH:
		{
			double e = 0.5 * c->spacing, d = outside ? 0.0 : od_MeshDistance(c, p);
			if (!outside && d >= 0.0)
			{
				*n = od_V3(0, 0, 1); // outside the mesh: no caller needs the normal
				return d;
			}
			od_Vec3 g;
			if (!od_MeshGradient(c, p, &d, &g)) // beyond the sample box: central differences that reach into it
			{
				d = od_MeshDistance(c, p);
				g = od_V3(od_MeshDistance(c, od_V3(p.x + e, p.y, p.z)) - od_MeshDistance(c, od_V3(p.x - e, p.y, p.z)),
						  od_MeshDistance(c, od_V3(p.x, p.y + e, p.z)) - od_MeshDistance(c, od_V3(p.x, p.y - e, p.z)),
						  od_MeshDistance(c, od_V3(p.x, p.y, p.z + e)) - od_MeshDistance(c, od_V3(p.x, p.y, p.z - e)));
			}
			double len = od_Length(g);
			*n = len > 0.0 ? od_Scale(1.0 / len, g) : od_V3(0, 0, 1);
			return d;
		}
	}
	*n = od_V3(0, 0, 1);
	return INFINITY;
}

// Signed distance and world normal at world point x for the current frame (a mesh skips the normal
// outside, where no caller needs it).
double od_Collider_Distance(const od_Collider* c, od_Vec3 x, od_Vec3* n)
{
	od_Vec3 local = od_M3MulTV(&c->R, od_Sub(x, c->t)), ln;
	double d = od_ShapeDistance(c, local, &ln, false);
	*n = od_M3MulV(&c->R, ln);
	return d;
}

double od_Collider_LocalDistance(const od_Collider* c, od_Vec3 p, od_Vec3* n)
{
	if (n == NULL && (c->kind == OD_SHAPE_MESH || c->kind == OD_SHAPE_OPEN_MESH))
	{
		return od_MeshDistance(c, p); // one lookup, not seven
	}
	od_Vec3 unused;
	return od_ShapeDistance(c, p, n ? n : &unused, true);
}

od_Vec3 od_Collider_Velocity(const od_Collider* c, od_Vec3 x)
{
	return od_Add(c->velocity, od_Cross(c->omega, od_Sub(x, c->t)));
}

static int od_IsRotation(const double* r)
{
	od_Mat3 m = od_M3Load(r), rtr = od_M3MulTN(&m, &m);
	for (int k = 0; k < 9; ++k)
	{
		if (!(fabs(rtr.m[k] - (k % 4 == 0)) < 1e-6))
		{
			return 0;
		}
	}
	return od_M3Det(&m) > 0.0;
}

od_Status od_Collider_SetTarget(od_Collider* c, const double rotation[9], const double translation[3])
{
	if (!od_IsRotation(rotation) || !od_IsFinite3(translation))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "collider: rotation must be a proper rotation and translation finite");
	}
	c->R1 = od_M3Load(rotation);
	c->t1 = od_V3Load(translation);
	return OD_OK;
}

od_Status od_Collider_Init(od_Collider* c, const od_ShapeDef* def, const double rotation[9], const double translation[3])
{
	*c = (od_Collider){ .kind = def->kind };
	if (def->kind < OD_SHAPE_PLANE || def->kind > OD_SHAPE_OPEN_MESH)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "collider: unknown shape %d", (int)def->kind);
	}
	const double* h = def->halfExtents;
	if ((def->kind == OD_SHAPE_BOX && !(h[0] > 0 && h[1] > 0 && h[2] > 0)) ||
		((def->kind == OD_SHAPE_SPHERE || def->kind == OD_SHAPE_CAPSULE) && !(h[0] > 0)) ||
		(def->kind == OD_SHAPE_CAPSULE && !(h[2] >= 0)) || !od_IsFinite3(h))
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "collider: box half extents, sphere and capsule radius must be > 0 (capsule half length >= 0)");
	}
	memcpy(c->halfExtents, h, sizeof c->halfExtents);
	od_Status status = od_Collider_SetTarget(c, rotation, translation);
	if (status != OD_OK)
	{
		return status;
	}
	c->R0 = c->R = c->R1;
	c->t0 = c->t = c->t1;
	c->radius = def->kind == OD_SHAPE_BOX ? od_Length(od_V3Load(h)) : (def->kind == OD_SHAPE_SPHERE ? h[0] : 0.0);
	c->radius = def->kind == OD_SHAPE_CAPSULE ? h[0] + h[2] : c->radius;
	if (def->kind == OD_SHAPE_MESH || def->kind == OD_SHAPE_OPEN_MESH)
	{
		status = od_MeshInit(c, def);
		if (status != OD_OK)
		{
			od_Collider_Destroy(c);
		}
	}
	return status;
}

void od_Collider_Destroy(od_Collider* c)
{
	od_Free(c->sdf);
	od_Free(c->side);
	c->sdf = c->side = NULL;
	c->capacity = 0;
}

void od_Collider_BeginCall(od_Collider* c, double duration)
{
	od_Mat3 delta = od_M3MulNT(&c->R1, &c->R0);
	c->omega = od_Scale(1.0 / duration, od_M3LogRotation(&delta));
	c->velocity = od_Scale(1.0 / duration, od_Sub(c->t1, c->t0));
}

void od_Collider_FrameAt(const od_Collider* c, double s, od_Mat3* R, od_Vec3* t)
{
	od_Mat3 delta = od_M3MulNT(&c->R1, &c->R0);
	od_Mat3 partial = od_M3ExpSkew(od_Scale(s, od_M3LogRotation(&delta)));
	*R = od_M3Mul(&partial, &c->R0);
	*t = od_MulAdd(c->t0, s, od_Sub(c->t1, c->t0));
}

void od_Collider_Place(od_Collider* c, double s)
{
	od_Collider_FrameAt(c, s, &c->R, &c->t);
}

void od_Collider_EndCall(od_Collider* c)
{
	c->R = c->R0 = c->R1;
	c->t = c->t0 = c->t1;
	c->velocity = c->omega = od_V3(0, 0, 0);
}

double od_Collider_MaxSpeed(const od_Collider* c)
{
	return od_Length(c->velocity) + od_Length(c->omega) * c->radius;
}


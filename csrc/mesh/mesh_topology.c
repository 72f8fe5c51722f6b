// The connected pieces of a triangle mesh, and for each its area, enclosed volume and whether it is closed.
//
// Welding first: vertices are snapped to a lattice of OD_WELD_FRACTION of the span (the diagonal of the bounding
// box of the triangles' vertices; a vertex of no triangle, however far, is not counted) and equal lattice points
// become one vertex (sorting, so deterministic). A span outside [OD_MIN_SPAN, OD_MAX_SPAN] is refused. Pieces are the connected components of
// the triangles over welded vertices, numbered by their first triangle. A piece is closed when every
// edge of its non-degenerate triangles is used by exactly two of them. Both sorts (welding, edges) poll the
// interrupt handler (od_Sort); their keys tie only for identical items, so the order is qsort's.
#include "mesh_graph.h"

#include "core.h"
#include "interrupt.h"
#include "math3.h"
#include "sort.h"
#include "union_find.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct od_WeldKey
{
	long long q[3];
	int vertex;
} od_WeldKey;

static int od_CompareWeldKeys(const void* pa, const void* pb)
{
	const od_WeldKey *a = pa, *b = pb;
	for (int k = 0; k < 3; ++k)
	{
		if (a->q[k] != b->q[k])
		{
			return a->q[k] < b->q[k] ? -1 : 1;
		}
	}
	return (a->vertex > b->vertex) - (a->vertex < b->vertex);
}

// The diagonal of the bounding box of the triangles' vertices (hypot: no overflow below 1e308), and its corner.
static double od_Span(const od_MeshGraphDef* def, double lo[3])
{
	double hi[3] = { -INFINITY, -INFINITY, -INFINITY };
	lo[0] = lo[1] = lo[2] = INFINITY;
	for (int t = 0; t < 3 * def->triangleCount; ++t)
	{
		for (int a = 0; a < 3; ++a)
		{
			lo[a] = fmin(lo[a], def->vertices[3 * def->triangles[t] + a]);
			hi[a] = fmax(hi[a], def->vertices[3 * def->triangles[t] + a]);
		}
	}
	if (def->triangleCount == 0)
	{
		lo[0] = lo[1] = lo[2] = hi[0] = hi[1] = hi[2] = 0.0;
	}
	return hypot(hypot(hi[0] - lo[0], hi[1] - lo[1]), hi[2] - lo[2]);
}

// weld[v] = the smallest vertex index at v's lattice point; *span = the span (see the top).
static od_Status od_Weld(const od_MeshGraphDef* def, int* weld, double* span)
{
	int nv = def->vertexCount;
	double lo[3];
	double diag = od_Span(def, lo);
	*span = diag;
	if (diag > OD_MAX_SPAN || (diag > 0.0 && diag < OD_MIN_SPAN))
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "vertices: the mesh spans %g m (the diagonal of its bounding box); it must span [%g, %g] m: "
					   "its particles' radii must be in [1e-12, 1e12] m (scale it, or change its units)",
					   diag, OD_MIN_SPAN, OD_MAX_SPAN);
	}
	double quantum = diag > 0.0 ? diag * OD_WELD_FRACTION : 1.0;
	od_WeldKey* keys = od_Alloc(sizeof(od_WeldKey) * (size_t)nv);
	if (!keys)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory welding %d vertices", nv);
	}
	for (int v = 0; v < nv; ++v)
	{
		for (int a = 0; a < 3; ++a)
		{
			keys[v].q[a] = llround(fmax(fmin((def->vertices[3 * v + a] - lo[a]) / quantum, 0x1p62), -0x1p62));
		}
		keys[v].vertex = v;
	}
	od_Status status = od_Sort(keys, (size_t)nv, sizeof *keys, od_CompareWeldKeys); // ties: none (the vertex)
	for (int i = 0, first = 0; i < nv && status == OD_OK; ++i)
	{
		if (memcmp(keys[i].q, keys[first].q, sizeof keys[i].q) != 0)
		{
			first = i;
		}
		weld[keys[i].vertex] = keys[first].vertex;
	}
	od_Free(keys);
	return status;
}

int od_CompareIntPairs(const void* pa, const void* pb)
{
	const int *a = pa, *b = pb;
	if (a[0] != b[0])
	{
		return a[0] < b[0] ? -1 : 1;
	}
	return (a[1] > b[1]) - (a[1] < b[1]);
}

// Marks pieces open where an edge (of a non-degenerate triangle) is not shared by exactly two triangles.
static od_Status od_MarkClosed(const od_MeshGraphDef* def, const int* weld, const int* pieceOfTriangle,
							   od_MeshPieces* p)
{
	int* edges = od_Alloc(sizeof(int) * 3 * 3 * (size_t)def->triangleCount); // (a, b, piece)
	if (!edges)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the edges of %d triangles", def->triangleCount);
	}
	int count = 0;
	for (int i = 0; i < p->count; ++i)
	{
		p->closed[i] = false;
	}
	for (int t = 0; t < def->triangleCount; ++t)
	{
		int v[3] = { weld[def->triangles[3 * t]], weld[def->triangles[3 * t + 1]], weld[def->triangles[3 * t + 2]] };
		if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0])
		{
			continue;
		}
		p->closed[pieceOfTriangle[t]] = true; // has a real triangle; edges below may still open it
		for (int k = 0; k < 3; ++k)
		{
			int a = v[k], b = v[(k + 1) % 3];
			int* e = edges + 3 * count++;
			e[0] = a < b ? a : b;
			e[1] = a < b ? b : a;
			e[2] = pieceOfTriangle[t];
		}
	}
	// Equal (a, b) have the same piece (a and b are joined), so only identical items tie.
	od_Status status = od_Sort(edges, (size_t)count, sizeof(int) * 3, od_CompareIntPairs);
	for (int i = 0; i < count && status == OD_OK;)
	{
		int j = i;
		while (j < count && edges[3 * j] == edges[3 * i] && edges[3 * j + 1] == edges[3 * i + 1])
		{
			++j;
		}
		if (j - i != 2)
		{
			p->closed[edges[3 * i + 2]] = false;
		}
		i = j;
	}
	od_Free(edges);
	return status;
}

static void od_Measure(const od_MeshGraphDef* def, const int* pieceOfTriangle, od_MeshPieces* p)
{
	for (int t = 0; t < def->triangleCount; ++t)
	{
		const int* tri = def->triangles + 3 * t;
		od_Vec3 a = od_V3Load(def->vertices + 3 * tri[0]), b = od_V3Load(def->vertices + 3 * tri[1]),
				c = od_V3Load(def->vertices + 3 * tri[2]);
		od_Vec3 n = od_Cross(od_Sub(b, a), od_Sub(c, a));
		p->area[pieceOfTriangle[t]] += 0.5 * od_Length(n);
		p->volume[pieceOfTriangle[t]] += od_Dot(a, od_Cross(b, c)) / 6.0;
	}
	for (int i = 0; i < p->count; ++i)
	{
		p->volume[i] = fabs(p->volume[i]);
	}
}

od_Status od_MeshPieces_Find(const od_MeshGraphDef* def, od_MeshPieces* p)
{
	memset(p, 0, sizeof *p);
	int nv = def->vertexCount, nt = def->triangleCount;
	int* weld = od_Alloc(sizeof(int) * (size_t)nv);
	int* parent = od_Alloc(sizeof(int) * (size_t)nv);
	int* pieceOf = od_Alloc(sizeof(int) * (size_t)nv); // piece of each root, then piece of each triangle
	int* pieceOfTriangle = od_Alloc(sizeof(int) * (size_t)nt);
	od_Status status = weld && parent && pieceOf && pieceOfTriangle
						   ? od_Weld(def, weld, &p->span)
						   : od_Fail(OD_ERROR_MEMORY, "out of memory finding the pieces of %d triangles", nt);
	status = status == OD_OK ? od_CheckInterrupt() : status;
	if (status == OD_OK)
	{
		od_UnionInit(parent, nv);
		for (int t = 0; t < nt; ++t)
		{
			const int* tri = def->triangles + 3 * t;
			od_Union(parent, weld[tri[0]], weld[tri[1]]);
			od_Union(parent, weld[tri[0]], weld[tri[2]]);
		}
		for (int v = 0; v < nv; ++v)
		{
			pieceOf[v] = -1;
		}
		for (int t = 0; t < nt; ++t)
		{
			int root = od_Find(parent, weld[def->triangles[3 * t]]);
			if (pieceOf[root] < 0)
			{
				pieceOf[root] = p->count++;
			}
			pieceOfTriangle[t] = pieceOf[root];
		}
		p->triangleStart = od_AllocZero((size_t)p->count + 1, sizeof(int));
		p->triangles = od_Alloc(sizeof(int) * (size_t)nt);
		p->area = od_AllocZero((size_t)p->count, sizeof(double));
		p->volume = od_AllocZero((size_t)p->count, sizeof(double));
		p->closed = od_AllocZero((size_t)p->count, sizeof(bool));
		p->pieceOfVertex = od_Alloc(sizeof(int) * (size_t)nv);
		if (!p->triangleStart || !p->triangles || !p->area || !p->volume || !p->closed || !p->pieceOfVertex)
		{
			status = od_Fail(OD_ERROR_MEMORY, "out of memory for %d mesh pieces", p->count);
		}
	}
	if (status == OD_OK)
	{
		for (int v = 0; v < nv; ++v)
		{
			p->pieceOfVertex[v] = pieceOf[od_Find(parent, weld[v])];
		}
		for (int t = 0; t < nt; ++t)
		{
			p->triangleStart[pieceOfTriangle[t] + 1]++;
		}
		for (int i = 0; i < p->count; ++i)
		{
			p->triangleStart[i + 1] += p->triangleStart[i];
		}
		memcpy(pieceOf, p->triangleStart, sizeof(int) * (size_t)p->count); // fill cursors
		for (int t = 0; t < nt; ++t)
		{
			p->triangles[pieceOf[pieceOfTriangle[t]]++] = t;
		}
		for (int v = 0; v < nv; ++v)
		{
			parent[v] = 0; // now: is the welded vertex used
		}
		for (int t = 0; t < 3 * nt; ++t)
		{
			int w = weld[def->triangles[t]];
			p->distinctVertices += parent[w] == 0;
			parent[w] = 1;
		}
		od_Measure(def, pieceOfTriangle, p);
		status = od_CheckInterrupt();
		status = status == OD_OK ? od_MarkClosed(def, weld, pieceOfTriangle, p) : status;
	}
	od_Free(weld);
	od_Free(parent);
	od_Free(pieceOf);
	od_Free(pieceOfTriangle);
	if (status != OD_OK)
	{
		od_MeshPieces_Destroy(p);
	}
	return status;
}

void od_MeshPieces_Destroy(od_MeshPieces* p)
{
	od_Free(p->triangleStart);
	od_Free(p->triangles);
	od_Free(p->area);
	od_Free(p->volume);
	od_Free(p->closed);
	od_Free(p->pieceOfVertex);
	memset(p, 0, sizeof *p);
}

// The rest graph: validation of user input, per-particle constants (volume, moment matrix) and the
// symmetric adjacency in CSR form. Everything here is computed once; the graph never changes after.
#include "graph.h"

#include "core.h"
#include "math3.h"
#include "polar.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

od_GraphDef od_DefaultGraphDef(void)
{
	od_GraphDef def;
	memset(&def, 0, sizeof def);
	return def;
}

static od_Status od_CheckParticles(const od_GraphDef* def)
{
	if (def->particleCount < 1)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "centers: a graph needs at least one particle, got %d", def->particleCount);
	}
	if (!def->centers || !def->radii)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "centers and radii are required");
	}
	for (int i = 0; i < def->particleCount; ++i)
	{
		if (!od_IsFinite3(def->centers + 3 * i))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "centers[%d] is not finite", i);
		}
		for (int k = 0; k < 3; ++k)
		{
			double r = def->radii[3 * i + k];
			if (!(r >= OD_MIN_RADIUS && r <= OD_MAX_RADIUS))
			{
				return od_Fail(OD_ERROR_ARGUMENT, "radii[%d][%d] = %g must be in [%g, %g] m", i, k, r, OD_MIN_RADIUS,
							   OD_MAX_RADIUS);
			}
		}
		if (def->axes)
		{
			od_Mat3 e = od_M3Load(def->axes + 9 * i);
			od_Mat3 ete = od_M3MulTN(&e, &e);
			double err = 0.0;
			for (int k = 0; k < 9; ++k)
			{
				double d = ete.m[k] - (k % 4 == 0 ? 1.0 : 0.0);
				err += d * d;
			}
			double det = od_M3Det(&e);
			if (!(err < 1e-12) || !(det > 0.0))
			{
				return od_Fail(OD_ERROR_ARGUMENT, "axes[%d] is not a proper rotation (|EᵀE - I|² = %.3g, det = %.6g)", i,
							   err, det);
			}
		}
	}
	return OD_OK;
}

static int od_CompareInt(const void* a, const void* b)
{
	int x = *(const int*)a, y = *(const int*)b;
	return (x > y) - (x < y);
}

static od_Status od_CheckEdges(const od_GraphDef* def)
{
	if (def->edgeCount < 0 || (def->edgeCount > 0 && !def->edges))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "edges: invalid edge count %d", def->edgeCount);
	}
	for (int e = 0; e < def->edgeCount; ++e)
	{
		int a = def->edges[2 * e], b = def->edges[2 * e + 1];
		if (a < 0 || b < 0 || a >= def->particleCount || b >= def->particleCount)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "edges[%d] = (%d, %d) is out of range: there are %d particles", e, a, b,
						   def->particleCount);
		}
		if (a == b)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "edges[%d] = (%d, %d) is a self-loop", e, a, b);
		}
	}
	return OD_OK;
}

static od_Status od_BuildAdjacency(od_Graph* g)
{
	int n = g->n;
	for (int e = 0; e < g->edgeCount; ++e)
	{
		g->adjStart[g->edges[2 * e] + 1]++;
		g->adjStart[g->edges[2 * e + 1] + 1]++;
	}
	for (int i = 0; i < n; ++i)
	{
		g->adjStart[i + 1] += g->adjStart[i];
	}
	int* fill = od_AllocZero((size_t)n, sizeof(int));
	if (!fill)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory building the adjacency");
	}
	for (int e = 0; e < g->edgeCount; ++e)
	{
		int a = g->edges[2 * e], b = g->edges[2 * e + 1];
		g->adj[g->adjStart[a] + fill[a]++] = b;
		g->adj[g->adjStart[b] + fill[b]++] = a;
	}
	od_Free(fill);
	for (int i = 0; i < n; ++i)
	{
		int* row = g->adj + g->adjStart[i];
		int count = g->adjStart[i + 1] - g->adjStart[i];
		qsort(row, (size_t)count, sizeof(int), od_CompareInt);
		for (int k = 1; k < count; ++k)
		{
			if (row[k] == row[k - 1])
			{
				return od_Fail(OD_ERROR_ARGUMENT, "edges: the edge (%d, %d) appears more than once", i, row[k]);
			}
		}
	}
	return OD_OK;
}

static void od_LabelPieces(od_Graph* g, int* stack)
{
	for (int i = 0; i < g->n; ++i)
	{
		g->piece[i] = -1;
	}
	g->pieceCount = 0;
	for (int seed = 0; seed < g->n; ++seed)
	{
		if (g->piece[seed] >= 0)
		{
			continue;
		}
		int top = 0;
		stack[top++] = seed;
		g->piece[seed] = g->pieceCount;
		while (top > 0)
		{
			int i = stack[--top];
			for (int k = g->adjStart[i]; k < g->adjStart[i + 1]; ++k)
			{
				int j = g->adj[k];
				if (g->piece[j] < 0)
				{
					g->piece[j] = g->pieceCount;
					stack[top++] = j;
				}
			}
		}
		g->pieceCount++;
	}
}

static void od_ComputeMoments(od_Graph* g)
{
	for (int i = 0; i < g->n; ++i)
	{
		const double* r = g->radii + 3 * i;
		double v = 4.0 / 3.0 * M_PI * r[0] * r[1] * r[2];
		g->volumes[i] = v;
		od_Mat3 e = od_M3Load(g->axes + 9 * i);
		od_Mat3 d = { { 0.2 * v * r[0] * r[0], 0, 0, 0, 0.2 * v * r[1] * r[1], 0, 0, 0, 0.2 * v * r[2] * r[2] } };
		od_Mat3 ed = od_M3Mul(&e, &d);
		od_Mat3 a = od_M3MulNT(&ed, &e);
		od_M3Store(g->moments + 9 * i, &a);
	}
}

static void od_ComputeBounds(od_Graph* g)
{
	for (int a = 0; a < 3; ++a)
	{
		g->lower[a] = INFINITY;
		g->upper[a] = -INFINITY;
	}
	for (int i = 0; i < g->n; ++i)
	{
		const double* r = g->radii + 3 * i;
		double reach = fmax(r[0], fmax(r[1], r[2]));
		for (int a = 0; a < 3; ++a)
		{
			g->lower[a] = fmin(g->lower[a], g->centers[3 * i + a] - reach);
			g->upper[a] = fmax(g->upper[a], g->centers[3 * i + a] + reach);
		}
	}
}

od_Status od_Graph_CheckRestPoint(const od_Graph* g, const double p[3], const char* name)
{
	double outside = 0.0, size = 0.0;
	for (int a = 0; a < 3; ++a)
	{
		double d = fmax(g->lower[a] - p[a], p[a] - g->upper[a]);
		outside = fmax(outside, d);
		size = hypot(size, g->upper[a] - g->lower[a]);
	}
	if (outside > OD_REST_POINT_REACH * size)
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "%s (%g, %g, %g) is %g m from the graph, more than %g times its size (%g m): a rest-space "
					   "point must lie on or near the body",
					   name, p[0], p[1], p[2], outside, OD_REST_POINT_REACH, size);
	}
	return OD_OK;
}

od_Status od_Graph_Create(const od_GraphDef* def, od_Graph** out)
{
	*out = NULL;
	od_Status status = od_CheckParticles(def);
	if (status == OD_OK)
	{
		status = od_CheckEdges(def);
	}
	if (status != OD_OK)
	{
		return status;
	}
	int n = def->particleCount, m = def->edgeCount;
	od_Graph* g = od_AllocZero(1, sizeof *g);
	if (!g)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory creating a graph of %d particles", n);
	}
	g->n = n;
	g->edgeCount = m;
	g->centers = od_Alloc(sizeof(double) * 3 * n);
	g->axes = od_Alloc(sizeof(double) * 9 * n);
	g->radii = od_Alloc(sizeof(double) * 3 * n);
	g->volumes = od_Alloc(sizeof(double) * n);
	g->moments = od_Alloc(sizeof(double) * 9 * n);
	g->edges = od_Alloc(sizeof(int) * 2 * m);
	g->adjStart = od_AllocZero((size_t)n + 1, sizeof(int));
	g->adj = od_Alloc(sizeof(int) * 2 * m);
	g->piece = od_Alloc(sizeof(int) * n);
	int* stack = od_Alloc(sizeof(int) * n);
	if (!g->centers || !g->axes || !g->radii || !g->volumes || !g->moments || !g->edges || !g->adjStart || !g->adj ||
		!g->piece || !stack)
	{
		od_Free(stack);
		od_Graph_Destroy(g);
		return od_Fail(OD_ERROR_MEMORY, "out of memory creating a graph of %d particles", n);
	}
	memcpy(g->centers, def->centers, sizeof(double) * 3 * n);
	memcpy(g->radii, def->radii, sizeof(double) * 3 * n);
	if (m > 0)
	{
		memcpy(g->edges, def->edges, sizeof(int) * 2 * m);
	}
	for (int i = 0; i < n; ++i)
	{
		od_Mat3 e = def->axes ? od_M3Load(def->axes + 9 * i) : od_M3Identity();
		od_Orthonormalize(&e); // inputs were checked to 1e-6; make them exact
		od_M3Store(g->axes + 9 * i, &e);
	}
	status = od_BuildAdjacency(g);
	if (status != OD_OK)
	{
		od_Free(stack);
		od_Graph_Destroy(g);
		return status;
	}
	od_LabelPieces(g, stack);
	od_Free(stack);
	od_ComputeMoments(g);
	od_ComputeBounds(g);
	*out = g;
	return OD_OK;
}

void od_Graph_Destroy(od_Graph* g)
{
	if (!g)
	{
		return;
	}
	od_Free(g->centers);
	od_Free(g->axes);
	od_Free(g->radii);
	od_Free(g->volumes);
	od_Free(g->moments);
	od_Free(g->edges);
	od_Free(g->adjStart);
	od_Free(g->adj);
	od_Free(g->piece);
	od_PieceMap_Destroy(g->meshPieces);
	od_Free(g);
}

int od_Graph_GetParticleCount(const od_Graph* g)
{
	return g->n;
}

int od_Graph_GetEdgeCount(const od_Graph* g)
{
	return g->edgeCount;
}

const double* od_Graph_GetCenters(const od_Graph* g)
{
	return g->centers;
}

const double* od_Graph_GetAxes(const od_Graph* g)
{
	return g->axes;
}

const double* od_Graph_GetRadii(const od_Graph* g)
{
	return g->radii;
}

const int* od_Graph_GetEdges(const od_Graph* g)
{
	return g->edges;
}

int od_Graph_GetPieces(const od_Graph* g, int* pieceOfParticle)
{
	if (pieceOfParticle)
	{
		memcpy(pieceOfParticle, g->piece, sizeof(int) * g->n);
	}
	return g->pieceCount;
}

od_Status od_Graph_SetMeshPieces(od_Graph* g, const od_PieceMapDef* def)
{
	od_PieceMap_Destroy(g->meshPieces);
	return od_PieceMap_Create(def, g->n, &g->meshPieces);
}

int od_Graph_GetMeshPieces(const od_Graph* g, int* meshPieceOfParticle)
{
	if (!g->meshPieces)
	{
		return 0;
	}
	if (meshPieceOfParticle)
	{
		memcpy(meshPieceOfParticle, g->meshPieces->particlePiece, sizeof(int) * g->n);
	}
	return g->meshPieces->pieceCount;
}

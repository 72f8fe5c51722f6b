// The stretch bound (od_Sim_SetStretchLimit): flesh stiffens as it stretches. At a call's start, each link's
// stretch of the skin at the call's end, as the particles' velocities carry them there (od_Over), past the limit L
// by t (over OD_STRETCH_RAMP, at most 1) raises its ends' link softness r to r^(1 - t): gently at first, all the
// way to 1 at L + OD_STRETCH_RAMP. The weights of a call are held through it (each step minimises one objective)
// and are a function of the call's start and its duration: a call from a restored state makes the same (a frame
// split into several calls looks ahead less far), a static solve uses the softness as set, and with no link
// past L the weights, the factor and the bits are those of the softness as set (docs/goals.md, "Stretch bound
// (stop 48)"). With a mesh set (od_Sim_SetStretchEdges) its edges are measured instead of each link's estimate:
// skinned from the particles ahead over their length in the goals' skin (od_MeshOver; docs/goals.md, "The stretch
// bound on the mesh's edges (stop 50)").
#include "stretch_bound.h"
#include "core.h"
#include "energy.h"
#include "goal.h"
#include "math3.h"

#include <math.h>
#include <string.h>

// The stretch over the limit at which a link's ends are raised all the way to 1.
#define OD_STRETCH_RAMP 0.1

void od_MakeLinkWeights(od_Sim* sim, const double* r)
{
	const od_Graph* g = sim->graph;
	for (int i = 0; i < g->n; ++i)
	{
		for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
		{
			sim->linkWeight[e] = od_SofterEnd(r, i, g->adj[e]);
		}
	}
}

// The rest vector d_ij of link (i, j) in particle i's frame: the goal shape's G_iᵀ (g_j - g_i) when the goals
// carry the rest, else the rest's c_j - c_i.
static od_Vec3 od_RestVector(const od_Sim* sim, int i, int j)
{
	if (!od_Goals_CarryRest(sim))
	{
		const double* c = sim->graph->centers;
		return od_Sub(od_V3Load(c + 3 * j), od_V3Load(c + 3 * i));
	}
	od_Mat3 gi = od_M3Load(sim->goals.R + 9 * i);
	return od_M3MulTV(&gi, od_Sub(od_V3Load(sim->goals.x + 3 * j), od_V3Load(sim->goals.x + 3 * i)));
}

// Each particle at the call's end (`ahead` seconds on) as its velocities carry it there: its centre into x (3n)
// and its rotation into R (9n).
static void od_Ahead(const od_Sim* sim, double ahead, double* x, double* R)
{
	const od_State* s = &sim->state;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Mat3 turn = od_M3ExpSkew(od_Scale(ahead, od_V3Load(s->omega + 3 * i))), now = od_M3Load(s->R + 9 * i);
		od_Mat3 r = od_M3Mul(&turn, &now);
		od_M3Store(R + 9 * i, &r);
		od_V3Store(x + 3 * i, od_MulAdd(od_V3Load(s->x + 3 * i), ahead, od_V3Load(s->v + 3 * i)));
	}
}

// The stretch link e = (i, j) adds to the skin between its ends at the call's end (od_Ahead's x, R): the gap at its
// middle between the skin its ends carry, δ = x_j - x_i - (R_i d_ij - R_j d_ji) / 2 (their stretch, and their
// disagreement on their turn where it parts the skin), times the link's skin gradient (the most half the
// difference of its ends' skin weights changes per metre along a mesh edge: a gap δ stretches such an edge by
// about |δ| g), or over the link's length |d_ij| without a gradient. Past the limit, over OD_STRETCH_RAMP, in
// [0, 1].
static double od_Over(const od_Sim* sim, const double* x, const double* R, int e)
{
	int i = sim->graph->edges[2 * e], j = sim->graph->edges[2 * e + 1];
	od_Mat3 ri = od_M3Load(R + 9 * i), rj = od_M3Load(R + 9 * j);
	od_Vec3 xi = od_V3Load(x + 3 * i), xj = od_V3Load(x + 3 * j);
	od_Vec3 dij = od_RestVector(sim, i, j), dji = od_RestVector(sim, j, i);
	od_Vec3 carried = od_Scale(0.5, od_Sub(od_M3MulV(&ri, dij), od_M3MulV(&rj, dji)));
	double gap = od_Length(od_Sub(od_Sub(xj, xi), carried));
	const double* g = sim->skinGradient;
	double length = od_Length(dij); // 0 where goal centres coincide: nothing to measure the stretch against
	double stretch = g ? gap * g[e] : (length > 0.0 ? gap / length : 0.0);
	return fmin(fmax(stretch - (sim->stretchLimit - 1.0), 0.0) / OD_STRETCH_RAMP, 1.0);
}

// The stretch bound's mesh (od_Sim_SetStretchEdges): its rest (3V), rest lengths (E), skin ahead and reference
// skin (3V each), in that order after the weights; its edges' ends (2E) and each vertex's mark (V) after the
// indices.
static double* od_MeshRest(const od_Sim* sim)
{
	return sim->stretchMesh.weights + (size_t)sim->stretchMesh.vertexCount * (size_t)sim->stretchMesh.neighbors;
}

static double* od_MeshRestLength(const od_Sim* sim)
{
	return od_MeshRest(sim) + 3 * (size_t)sim->stretchMesh.vertexCount;
}

static double* od_MeshAhead(const od_Sim* sim)
{
	return od_MeshRestLength(sim) + sim->stretchMesh.edgeCount;
}

static int* od_MeshEnds(const od_Sim* sim)
{
	return sim->stretchMesh.indices + (size_t)sim->stretchMesh.vertexCount * (size_t)sim->stretchMesh.neighbors;
}

static int* od_MeshMarks(const od_Sim* sim)
{
	return od_MeshEnds(sim) + 2 * (size_t)sim->stretchMesh.edgeCount;
}

// A vertex's marks: a particle of link softness < 1 skins it (its edges are measured: a raise could change it),
// and a measured edge ends at it (its skin is needed).
enum
{
	OD_SOFT_VERTEX = 1,
	OD_SKINNED_VERTEX = 2
};

// Each vertex marked for this call (od_MeshMarks): with a soft particle, then skinned where a measured edge ends.
static void od_MarkMesh(const od_Sim* sim)
{
	const int m = sim->stretchMesh.neighbors, *index = sim->stretchMesh.indices, *ends = od_MeshEnds(sim);
	const double *w = sim->stretchMesh.weights, *r = sim->linkSoftness;
	int* mark = od_MeshMarks(sim);
	for (int v = 0; v < sim->stretchMesh.vertexCount; ++v)
	{
		mark[v] = 0;
		for (int k = m * v; k < m * (v + 1); ++k)
		{
			mark[v] |= w[k] > 0.0 && r[index[k]] < 1.0 ? OD_SOFT_VERTEX : 0;
		}
	}
	for (int e = 0; e < sim->stretchMesh.edgeCount; ++e)
	{
		int a = ends[2 * e], b = ends[2 * e + 1];
		if ((mark[a] | mark[b]) & OD_SOFT_VERTEX)
		{
			mark[a] |= OD_SKINNED_VERTEX;
			mark[b] |= OD_SKINNED_VERTEX;
		}
	}
}

// The marked vertices skinned by linear blending from the frames x (3n), R (9n) into out (3V).
static void od_MeshSkin(const od_Sim* sim, const double* x, const double* R, double* out)
{
	const int m = sim->stretchMesh.neighbors, *index = sim->stretchMesh.indices, *mark = od_MeshMarks(sim);
	const double *w = sim->stretchMesh.weights, *rest = od_MeshRest(sim), *c = sim->graph->centers;
	for (int v = 0; v < sim->stretchMesh.vertexCount; ++v)
	{
		od_Vec3 sum = { 0.0, 0.0, 0.0 }, p = od_V3Load(rest + 3 * v);
		for (int k = m * v; (mark[v] & OD_SKINNED_VERTEX) && k < m * (v + 1); ++k)
		{
			if (w[k] > 0.0)
			{
				od_Mat3 r = od_M3Load(R + 9 * index[k]);
				od_Vec3 carried = od_Add(od_V3Load(x + 3 * index[k]), od_M3MulV(&r, od_Sub(p, od_V3Load(c + 3 * index[k]))));
				sum = od_MulAdd(sum, w[k], carried);
			}
		}
		od_V3Store(out + 3 * v, sum);
	}
}

static double od_Distance(const double* p, int a, int b)
{
	return od_Length(od_Sub(od_V3Load(p + 3 * b), od_V3Load(p + 3 * a)));
}

// The particles that skin vertex v raised to at least t (most, n).
static void od_RaiseVertex(const od_Sim* sim, int v, double t, double* most)
{
	const int m = sim->stretchMesh.neighbors;
	for (int k = m * v; k < m * (v + 1); ++k)
	{
		if (sim->stretchMesh.weights[k] > 0.0)
		{
			int i = sim->stretchMesh.indices[k];
			most[i] = fmax(most[i], t);
		}
	}
}

// Each mesh edge's stretch at the call's end (the skin of od_Ahead's x, R) over its reference length (the goal
// skin's while the goals carry the rest, else the rest's), past the limit over OD_STRETCH_RAMP, raises the
// particles that skin its ends (most, n). Only edges with a soft end are measured (a raise of the others changes
// nothing).
static void od_MeshOver(od_Sim* sim, const double* x, const double* R, double* most)
{
	double *ahead = od_MeshAhead(sim), *reference = ahead + 3 * (size_t)sim->stretchMesh.vertexCount;
	const double* restLength = od_MeshRestLength(sim);
	const int *ends = od_MeshEnds(sim), *mark = od_MeshMarks(sim);
	bool goals = od_Goals_CarryRest(sim);
	od_MarkMesh(sim);
	od_MeshSkin(sim, x, R, ahead);
	if (goals)
	{
		od_MeshSkin(sim, sim->goals.x, sim->goals.R, reference);
	}
	for (int e = 0; e < sim->stretchMesh.edgeCount; ++e)
	{
		int a = ends[2 * e], b = ends[2 * e + 1];
		double length = goals ? od_Distance(reference, a, b) : restLength[e];
		double stretch = length > 0.0 && ((mark[a] | mark[b]) & OD_SOFT_VERTEX) ? od_Distance(ahead, a, b) / length : 0.0;
		double t = fmin(fmax(stretch - sim->stretchLimit, 0.0) / OD_STRETCH_RAMP, 1.0);
		if (t > 0.0)
		{
			od_RaiseVertex(sim, a, t, most);
			od_RaiseVertex(sim, b, t, most);
		}
	}
}

// The links' estimate (od_Over) of each link with a soft end, raising its ends (most, n).
static void od_LinksOver(od_Sim* sim, const double* x, const double* R, double* most)
{
	const double* r = sim->linkSoftness;
	for (int e = 0; e < sim->graph->edgeCount; ++e)
	{
		int i = sim->graph->edges[2 * e], j = sim->graph->edges[2 * e + 1];
		double t = r[i] < 1.0 || r[j] < 1.0 ? od_Over(sim, x, R, e) : 0.0; // a stiff link has nothing to raise
		most[i] = fmax(most[i], t);
		most[j] = fmax(most[j], t);
	}
}

void od_StretchBound_Lower(od_Sim* sim)
{
	size_t bytes = sizeof(double) * (size_t)sim->graph->n;
	if (sim->linkSoftness && sim->linkRaised && memcmp(sim->linkRaised, sim->linkSoftness, bytes))
	{
		memcpy(sim->linkRaised, sim->linkSoftness, bytes);
		od_MakeLinkWeights(sim, sim->linkSoftness);
		sim->stiffnessVersion++;
		sim->edgeStiffness = 0.0;
	}
}

// Whether any of the n particles has softened links (r < 1): else no link has anything to raise, and the raised
// softness is r (od_Sim_SetStretchLimit, od_FillLinkWeights and each call here leave it so).
static bool od_Softened(const double* r, int n)
{
	for (int i = 0; i < n; ++i)
	{
		if (r[i] < 1.0)
		{
			return true;
		}
	}
	return false;
}

void od_StretchBound(od_Sim* sim, double ahead)
{
	const double* r = sim->linkSoftness;
	double* raised = sim->linkRaised;
	int n = sim->graph->n;
	if (!r || !raised || !od_Softened(r, n))
	{
		return;
	}
	double *most = raised + n, *x = most + n, *R = x + 3 * n; // the scratch (od_Sim_SetStretchLimit)
	memset(most, 0, sizeof(double) * (size_t)n);
	od_Ahead(sim, ahead, x, R);
	if (sim->stretchMesh.vertexCount > 0)
	{
		od_MeshOver(sim, x, R, most);
	}
	else
	{
		od_LinksOver(sim, x, R, most);
	}
	bool changed = false;
	for (int i = 0; i < n; ++i)
	{
		double value = most[i] > 0.0 ? pow(r[i], 1.0 - most[i]) : r[i];
		changed = changed || value != raised[i];
		raised[i] = value;
	}
	if (changed)
	{
		od_MakeLinkWeights(sim, raised);
		sim->stiffnessVersion++;
		sim->edgeStiffness = 0.0; // the edges' terms are made again (local_step.c)
	}
}

// Whether the stretch mesh's arguments are valid (else the failure, naming the first bad value).
static od_Status od_CheckStretchEdges(const od_Sim* sim, int vertexCount, int neighbors, const int* indices,
									  const double* weights, const double* rest, int edgeCount, const int* edges)
{
	if (vertexCount < 0 || neighbors < 1 || edgeCount < 0 || !indices || !weights || !rest || (edgeCount && !edges))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "stretch edges: %d vertices of %d neighbors and %d edges (arrays given)",
					   vertexCount, neighbors, edgeCount);
	}
	for (int k = 0; k < vertexCount * neighbors; ++k)
	{
		bool none = indices[k] == -1 && weights[k] == 0.0;
		if (!none && !(indices[k] >= 0 && indices[k] < sim->graph->n && weights[k] >= 0.0 && isfinite(weights[k])))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "stretch edges: vertex %d's particle %d of weight %g (of %d particles)",
						   k / neighbors, indices[k], weights[k], sim->graph->n);
		}
	}
	for (int k = 0; k < 3 * vertexCount; ++k)
	{
		if (!isfinite(rest[k]))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "stretch edges: rest[%d] = %g must be finite", k, rest[k]);
		}
	}
	for (int k = 0; k < 2 * edgeCount; ++k)
	{
		if (edges[k] < 0 || edges[k] >= vertexCount)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "stretch edges: edges[%d] = %d is not one of the %d vertices", k / 2,
						   edges[k], vertexCount);
		}
	}
	return OD_OK;
}

od_Status od_Sim_SetStretchEdges(od_Sim* sim, int vertexCount, int neighbors, const int* indices,
								 const double* weights, const double* rest, int edgeCount, const int* edges)
{
	od_Status status = vertexCount == 0 ? OD_OK
						   : od_CheckStretchEdges(sim, vertexCount, neighbors, indices, weights, rest, edgeCount, edges);
	if (status != OD_OK)
	{
		return status;
	}
	od_Free(sim->stretchMesh.indices);
	od_Free(sim->stretchMesh.weights);
	memset(&sim->stretchMesh, 0, sizeof(sim->stretchMesh));
	if (vertexCount == 0)
	{
		return OD_OK;
	}
	size_t links = (size_t)vertexCount * (size_t)neighbors, values = links + 9 * (size_t)vertexCount + (size_t)edgeCount;
	sim->stretchMesh.indices = od_Alloc(sizeof(int) * (links + 2 * (size_t)edgeCount + (size_t)vertexCount));
	sim->stretchMesh.weights = od_Alloc(sizeof(double) * values);
	if (!sim->stretchMesh.indices || !sim->stretchMesh.weights)
	{
		od_Sim_SetStretchEdges(sim, 0, 0, NULL, NULL, NULL, 0, NULL);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the stretch bound's %d vertices", vertexCount);
	}
	sim->stretchMesh.vertexCount = vertexCount;
	sim->stretchMesh.neighbors = neighbors;
	sim->stretchMesh.edgeCount = edgeCount;
	memcpy(sim->stretchMesh.indices, indices, sizeof(int) * links);
	if (edgeCount)
	{
		memcpy(sim->stretchMesh.indices + links, edges, sizeof(int) * 2 * (size_t)edgeCount);
	}
	memcpy(sim->stretchMesh.weights, weights, sizeof(double) * links);
	memcpy(od_MeshRest(sim), rest, sizeof(double) * 3 * (size_t)vertexCount);
	for (int e = 0; e < edgeCount; ++e)
	{
		od_MeshRestLength(sim)[e] = od_Distance(rest, edges[2 * e], edges[2 * e + 1]);
	}
	return OD_OK;
}

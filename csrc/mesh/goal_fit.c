// Goal frames from an animated mesh, the input of od_Sim_SetGoals: each particle's goal is the rigid
// motion that best carries its k nearest rest vertices onto their animated positions. Weighted least
// squares (Kabsch): the weighted centroids x̄, ȳ, then R = the polar rotation of the cross-covariance
// Σ w (y - ȳ)(x - x̄)ᵀ, and the goal centre ȳ + R (X̄ - x̄). The weights are the Sumner weights of the
// skin (graph/skin_weights.c) over the k nearest vertices of the particle's rest centre, so a particle
// follows the part of the surface it stands for; for a graph built from a mesh of several pieces, the k nearest
// of the vertices it skins (its own piece's and those of the pieces it carries, piece_map.c): the kid's 8-vertex
// backpack, against the body's back, had 6 of its 8 particles at 100 particles fitted 98-100 % to the body's
// vertices, so they turned with the chest and took its painted values (docs/goals.md). Binding finds the neighbours once (a grid over the
// vertices, polling for interrupts every 1,024 particles); a fit is O(particles · k), reads only those vertices (a NaN
// elsewhere in the mesh does not reach the goals) and allocates nothing. Each particle's rotation: Newton steps on
// SO(3) (od_PolarRotationNewton) from the rotation of the particle fitted before it in the same call (the first
// from the identity), to rounding, the SVD where they do not clearly converge: the same rotation as the SVD's to
// 1e-15 and 2.2x faster than the SVD alone (1,000 particles on the 5,752-vertex character, 0.41 -> 0.19 ms). The
// start depends on this call's input only, never on an earlier call's, so a frame's goals are the same bits
// whatever was fitted before (bake = playback). The vertices read are checked where a particle's centroid comes
// out not finite, not all before the fit (0.182 -> 0.167 ms at 1,000 particles on the character, the same bits).
#include "opdeform/mesh.h"

#include "check.h"
#include "core.h"
#include "interrupt.h"
#include "graph.h"
#include "math3.h"
#include "mesh_check.h"
#include "nearest.h"
#include "polar.h"
#include "skin_weights.h"

#include <string.h>

#define OD_GOAL_FIT_POLL 1023 // particles bound between interrupt checks, less one (a power of two less one)
#define OD_GOAL_FIT_STEP2 1e-20 // Newton stops after a step under 1e-10 rad: what is left is rounding

struct od_GoalFit
{
	int particleCount, vertexCount, k;
	double* centers; // particleCount*3, X̄
	int* idx;        // particleCount*k vertex indices
	double* w;       // particleCount*k weights, summing to 1 per particle
	double* centroid; // particleCount*3, x̄: the weighted rest centroid of each particle's vertices
	double* rest;     // vertexCount*3 rest vertices
};

od_GoalFitDef od_DefaultGoalFitDef(void)
{
	return (od_GoalFitDef){ .neighbors = 16 };
}

void od_GoalFit_Destroy(od_GoalFit* fit)
{
	if (fit)
	{
		od_Free(fit->centers);
		od_Free(fit->idx);
		od_Free(fit->w);
		od_Free(fit->centroid);
		od_Free(fit->rest);
		od_Free(fit);
	}
}

// Each rest vertex's piece, for a graph built from a mesh of several pieces: the piece whose particles skin it
// (piece_map.c), so that a particle fits only the vertices it skins; *label stays NULL (any vertex) otherwise.
// count: the vertices of each piece.
static od_Status od_LabelVertices(const od_Graph* graph, const double* vertices, int vertexCount, int** label,
								  int** count)
{
	const od_PieceMap* map = graph->meshPieces;
	*label = *count = NULL;
	if (!map || map->pieceCount < 2)
	{
		return OD_OK;
	}
	*label = od_Alloc(sizeof(int) * (size_t)vertexCount);
	*count = od_AllocZero((size_t)map->pieceCount, sizeof(int));
	if (!*label || !*count)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the pieces of %d goal vertices", vertexCount);
	}
	for (int v = 0; v < vertexCount; ++v)
	{
		int size;
		od_PieceMap_Locate(map, vertices + 3 * v, *label + v, &size);
		(*count)[(*label)[v]]++;
	}
	return OD_OK;
}

// The k + 1 nearest rest vertices of particle j, those of its own piece where the vertices are labelled (a piece
// without vertices takes any); returns how many were found.
static int od_NearestVertices(const od_GoalFit* fit, const od_NearestGrid* grid, const od_Graph* graph,
							  const int* label, const int* count, int j, double* dist, int* near)
{
	int want = label ? graph->meshPieces->particlePiece[j] : 0;
	int k = fit->k + 1;
	if (label && count[want] == 0)
	{
		label = NULL;
	}
	k = label && count[want] < k ? count[want] : k;
	return od_NearestGrid_Query(grid, label, want, graph->centers + 3 * j, k, dist, near);
}

static od_Status od_Bind(od_GoalFit* fit, const od_Graph* graph, const double* vertices)
{
	od_NearestGrid grid;
	int *label, *count;
	od_Status status = od_LabelVertices(graph, vertices, fit->vertexCount, &label, &count);
	status = status == OD_OK ? od_NearestGrid_Create(&grid, vertices, fit->vertexCount) : status;
	if (status != OD_OK)
	{
		od_Free(label);
		od_Free(count);
		return status;
	}
	double dist[OD_MAX_GOAL_NEIGHBORS + 1];
	int near[OD_MAX_GOAL_NEIGHBORS + 1];
	for (int j = 0; j < fit->particleCount; ++j)
	{
		status = (j & OD_GOAL_FIT_POLL) == 0 ? od_CheckInterrupt() : OD_OK;
		if (status != OD_OK)
		{
			break;
		}
		int* idx = fit->idx + (size_t)fit->k * j;
		double* w = fit->w + (size_t)fit->k * j;
		int found = od_NearestVertices(fit, &grid, graph, label, count, j, dist, near);
		int used = od_SumnerWeights(dist, near, found, fit->k, idx, w);
		od_Vec3 centroid = od_V3(0, 0, 0);
		for (int a = 0; a < fit->k; ++a)
		{
			idx[a] = a < used ? idx[a] : idx[0];
			w[a] = a < used ? w[a] : 0.0;
			centroid = od_MulAdd(centroid, w[a], od_V3Load(vertices + 3 * idx[a]));
		}
		od_V3Store(fit->centroid + 3 * j, centroid);
	}
	od_NearestGrid_Destroy(&grid);
	od_Free(label);
	od_Free(count);
	return status;
}

od_Status od_GoalFit_Create(const od_Graph* graph, const od_GoalFitDef* def, od_GoalFit** out)
{
	*out = NULL;
	if (!graph || !def || def->vertexCount < 1 || !def->vertices)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "goal fit: a graph and at least one rest vertex are required");
	}
	if (def->neighbors < 1 || def->neighbors > OD_MAX_GOAL_NEIGHBORS)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "neighbors = %d must be in [1, %d]", def->neighbors, OD_MAX_GOAL_NEIGHBORS);
	}
	od_Status status = od_CheckFinite("vertices", def->vertices, 3 * def->vertexCount);
	if (status != OD_OK)
	{
		return status;
	}
	od_GoalFit* fit = od_AllocZero(1, sizeof *fit);
	if (!fit)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for a goal fit");
	}
	size_t n = (size_t)graph->n;
	fit->particleCount = graph->n;
	fit->vertexCount = def->vertexCount;
	fit->k = def->neighbors < def->vertexCount ? def->neighbors : def->vertexCount;
	fit->centers = od_Alloc(sizeof(double) * 3 * n);
	fit->idx = od_Alloc(sizeof(int) * fit->k * n);
	fit->w = od_Alloc(sizeof(double) * fit->k * n);
	fit->centroid = od_Alloc(sizeof(double) * 3 * n);
	fit->rest = od_Alloc(sizeof(double) * 3 * (size_t)def->vertexCount);
	status = fit->centers && fit->idx && fit->w && fit->centroid && fit->rest ? OD_OK : od_Fail(OD_ERROR_MEMORY, "out of memory for a goal fit");
	if (status == OD_OK)
	{
		memcpy(fit->centers, graph->centers, sizeof(double) * 3 * n);
		memcpy(fit->rest, def->vertices, sizeof(double) * 3 * (size_t)def->vertexCount);
		status = od_Bind(fit, graph, def->vertices);
	}
	if (status != OD_OK)
	{
		od_GoalFit_Destroy(fit);
		return status;
	}
	*out = fit;
	return OD_OK;
}

int od_GoalFit_GetVertexCount(const od_GoalFit* fit)
{
	return fit->vertexCount;
}

int od_GoalFit_GetNeighborCount(const od_GoalFit* fit)
{
	return fit->k;
}

const int* od_GoalFit_GetIndices(const od_GoalFit* fit)
{
	return fit->idx;
}

const double* od_GoalFit_GetWeights(const od_GoalFit* fit)
{
	return fit->w;
}

// The fit is inlined into each entry point with its kind of input known there, so that reading a vertex has no
// branch left (the float64 fit: 0.19-0.20 ms warm before and after, the character at 1,000 particles; the float32
// one 0.21, its conversions).
#if defined(__GNUC__) || defined(__clang__)
#define OD_FIT_INLINE static inline __attribute__((always_inline))
#else
#define OD_FIT_INLINE static inline
#endif

// The animated vertices: float64, or float32 each moved by a shift in float64 (od_GoalFit_ComputeShifted).
typedef struct od_Animated
{
	const double* d; // NULL: f and shift
	const float* f;
	od_Vec3 shift;
	bool shifted; // false: a zero shift, not added (adding zeros would turn -0.0 into 0.0)
} od_Animated;

OD_FIT_INLINE od_Vec3 od_AnimatedVertex(const od_Animated* in, int i)
{
	if (in->d)
	{
		return od_V3Load(in->d + 3 * (size_t)i);
	}
	const float* f = in->f + 3 * (size_t)i;
	od_Vec3 v = od_V3(f[0], f[1], f[2]);
	return in->shifted ? od_Add(v, in->shift) : v;
}

// The rigid motion of particle j's vertices from rest to `animated`; *warm: the rotation Newton's steps start from,
// left holding this particle's. False, with nothing written, when the weighted centroid of its animated vertices
// is not finite: one of them is not (a weight 0 times it is NaN too), or their sum overflows.
OD_FIT_INLINE bool od_FitOne(const od_GoalFit* fit, const od_Animated* animated, int j, od_Mat3* warm,
							 double* position, double* rotation)
{
	const int* idx = fit->idx + (size_t)fit->k * j;
	const double* w = fit->w + (size_t)fit->k * j;
	od_Vec3 xbar = od_V3Load(fit->centroid + 3 * j), ybar = od_V3(0, 0, 0);
	od_Vec3 y[OD_MAX_GOAL_NEIGHBORS]; // the vertices read (and converted, shifted) once for both passes
	for (int a = 0; a < fit->k; ++a)
	{
		y[a] = od_AnimatedVertex(animated, idx[a]);
		ybar = od_MulAdd(ybar, w[a], y[a]);
	}
	if (!isfinite(ybar.x) || !isfinite(ybar.y) || !isfinite(ybar.z))
	{
		return false;
	}
	od_Mat3 cov = { { 0 } };
	for (int a = 0; a < fit->k; ++a)
	{
		od_Vec3 x = od_Sub(od_V3Load(fit->rest + 3 * idx[a]), xbar);
		od_M3AddOuter(&cov, w[a], od_Sub(y[a], ybar), x);
	}
	double size = 0.0;
	for (int k = 0; k < 9; ++k)
	{
		double a = fabs(cov.m[k]);
		size = a > size ? a : size; // fmax's value (a NaN is skipped) without its call into libm
	}
	if (size > 1e100 || (size > 0.0 && size < 1e-100)) // R ignores a positive scale; its products would overflow
	{
		for (int k = 0; k < 9; ++k)
		{
			cov.m[k] /= size;
		}
	}
	od_PolarRotationNewton(&cov, warm, OD_GOAL_FIT_STEP2);
	od_M3Store(rotation, warm);
	od_V3Store(position, od_Add(ybar, od_M3MulV(warm, od_Sub(od_V3Load(fit->centers + 3 * j), xbar))));
	return true;
}

// The vertices a fit reads (k per particle, not the whole mesh) must be finite.
static od_Status od_CheckUsed(const od_GoalFit* fit, const od_Animated* animated)
{
	for (size_t a = 0; a < (size_t)fit->k * fit->particleCount; ++a)
	{
		od_Vec3 v = od_AnimatedVertex(animated, fit->idx[a]);
		if (!isfinite(v.x) || !isfinite(v.y) || !isfinite(v.z))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "animated vertices[%d] is not finite", fit->idx[a]);
		}
	}
	return OD_OK;
}

OD_FIT_INLINE od_Status od_Compute(const od_GoalFit* fit, const od_Animated* animated, double* positions,
								   double* rotations)
{
	od_Mat3 warm = { { 1, 0, 0, 0, 1, 0, 0, 0, 1 } };
	for (int j = 0; j < fit->particleCount; ++j)
	{
		double* r = rotations + 9 * j;
		bool finite = od_FitOne(fit, animated, j, &warm, positions + 3 * j, r) && od_IsFinite3(positions + 3 * j);
		for (int k = 0; finite && k < 9; ++k)
		{
			finite = isfinite(r[k]);
		}
		if (!finite)
		{
			// a vertex that is not finite is named first, as if checked before fitting (what it reads is checked
			// only here: every non-finite vertex makes some particle's centroid non-finite)
			od_Status status = od_CheckUsed(fit, animated);
			return status != OD_OK ? status
								   : od_Fail(OD_ERROR_ARGUMENT,
											 "animated vertices: particle %d's goal frame overflows (coordinates too "
											 "large to fit, e.g. %g)",
											 j, od_AnimatedVertex(animated, fit->idx[(size_t)fit->k * j]).x);
		}
	}
	return OD_OK;
}

od_Status od_GoalFit_Compute(const od_GoalFit* fit, const double* animated, double* positions, double* rotations)
{
	od_Animated in = { animated, NULL, { 0, 0, 0 }, false };
	return od_Compute(fit, &in, positions, rotations);
}

od_Status od_GoalFit_ComputeShifted(const od_GoalFit* fit, const float* animated, const double shift[3],
									double* positions, double* rotations)
{
	if (shift[0] != 0.0 || shift[1] != 0.0 || shift[2] != 0.0)
	{
		od_Animated in = { NULL, animated, od_V3Load(shift), true };
		return od_Compute(fit, &in, positions, rotations);
	}
	od_Animated in = { NULL, animated, od_V3(0, 0, 0), false };
	return od_Compute(fit, &in, positions, rotations);
}

// Whether every coordinate is finite; OD_ERROR_ARGUMENT naming the first vertex that is not.
static od_Status od_CheckAllFinite(const float* vertices, int count)
{
	for (int i = 0; i < count; ++i)
	{
		const float* v = vertices + 3 * (size_t)i;
		if (!isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2]))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "animated vertices[%d] is not finite", i);
		}
	}
	return OD_OK;
}

// Whether the input and shift equal the kept ones value for value (== : -0.0 equals 0.0, as numpy's array_equal).
static bool od_SameAsKept(const od_KeptInput* kept, const float* animated, const double shift[3], int count)
{
	if (!kept->valid || shift[0] != kept->shift[0] || shift[1] != kept->shift[1] || shift[2] != kept->shift[2])
	{
		return false;
	}
	for (size_t i = 0; i < 3 * (size_t)count; ++i)
	{
		if (animated[i] != kept->vertices[i])
		{
			return false;
		}
	}
	return true;
}

od_Status od_GoalFit_Follow(const od_GoalFit* fit, const float* animated, const double shift[3], od_KeptInput* kept,
							bool* fitted, double* positions, double* rotations)
{
	*fitted = false;
	od_Status status = od_CheckAllFinite(animated, fit->vertexCount);
	if (status != OD_OK || od_SameAsKept(kept, animated, shift, fit->vertexCount))
	{
		return status;
	}
	status = od_GoalFit_ComputeShifted(fit, animated, shift, positions, rotations);
	if (status != OD_OK)
	{
		return status;
	}
	memcpy(kept->vertices, animated, sizeof(float) * 3 * (size_t)fit->vertexCount);
	memcpy(kept->shift, shift, sizeof(double) * 3);
	kept->valid = true;
	*fitted = true;
	return OD_OK;
}

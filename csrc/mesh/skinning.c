// Linear-blend skinning (eq. 1) with the Sumner weights of graph/skin_weights.c.
//
// od_Skin binds every vertex once and then deforms per frame: each particle's rigid motion is folded into
// one 3x4 affine map [Rj | xj - Rj X̄j], every vertex blends its m maps and applies the blend to its rest
// position (and the linear part to its rest normal). The vertex loop streams the rest positions,
// indices, weights and outputs once, so it runs near memory bandwidth. A large mesh keeps a thread pool
// (pool.c) that takes chunks of vertices; each vertex is computed alone, so the result does not depend on
// the number of threads, bit for bit. On x86-64 processors with AVX2 + FMA the m = 4 blend takes each map as
// 4 columns of 4 doubles (od_BlendBlockAvx2), the streams are prefetched ahead and a large mesh's float32
// outputs are written with streaming stores (1.5 to 1.7x the SSE2 loop at 1M vertices, docs/speed.md);
// OPDEFORM_NO_AVX2=1 keeps the SSE2 loop. The two agree to rounding (about 1e-16 relative).
#include "opdeform/mesh.h"

#include "core.h"
#include "graph.h"
#include "interrupt.h"
#include "math3.h"
#include "mesh_check.h"
#include "nearest.h"
#include "platform.h"
#include "pool.h"
#include "skin_weights.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#ifdef OD_X86_AVX2
// x86-64 builds target the baseline (SSE2); the m = 4 blend has a second version for AVX2 + FMA, chosen at run
// time (od_Platform_HasAvx2Fma) where the processor and the operating system support it.
#define OD_SKIN_AVX2 1
#endif
#ifndef OD_STREAM_VERTICES
#define OD_STREAM_VERTICES (1 << 18) // meshes from this size on stream their float32 outputs (AVX2 path)
#endif
#ifdef OD_SKIN_AVX2
#ifndef OD_SKIN_PREFETCH
#define OD_SKIN_PREFETCH 32 // vertices ahead (a prefetch past the end is only a hint: it never faults)
#endif
#include <immintrin.h>
#endif

// Vertices per task of the pool, when deforming and when binding; meshes below two deform chunks get no pool.
#define OD_DEFORM_CHUNK 8192
#define OD_BIND_CHUNK 1024
// One vertex on one thread, in nanoseconds, when deforming and when binding: the pool's measure of the work
// (docs/speed.md).
#define OD_DEFORM_NS 6.0
#define OD_BIND_NS 600.0
// Vertices bound between interrupt checks (about 0.7 us each on one core with 2,000 particles: ~10 ms).
#define OD_BIND_BATCH 16384

struct od_Skin
{
	int vertexCount;
	int particleCount;
	int m;
	double* rest;        // vertexCount*3
	double* restNormals; // vertexCount*3 or NULL
	int* idx;            // vertexCount*m
	double* w;           // vertexCount*m
	double* centers;     // particleCount*3, X̄
	od_Pool* pool;       // NULL: one thread
	double* maps;        // particleCount*12, each particle's affine map of a deform, 32-byte aligned
	double* mapStore;    // the allocation of maps (allocated once)
	double* columns;     // particleCount*16: the same maps as 4 columns of 4 (the AVX2 path), 32-byte aligned
	double* columnStore; // its allocation, or NULL without the AVX2 path
};

// Whether the AVX2 + FMA blend runs (platform.c: the processor, the operating system, OPDEFORM_NO_AVX2).
static bool od_SkinUsesAvx2(void)
{
#ifdef OD_SKIN_AVX2
	return od_Platform_HasAvx2Fma();
#else
	return false;
#endif
}

// Runs fn over [begin, end) in chunks, on the pool when there is one.
typedef void od_RangeFn(void* context, int begin, int end);

typedef struct od_RangeJob
{
	od_RangeFn* fn;
	void* context;
	int begin, end, chunk;
} od_RangeJob;

static void od_RunChunk(void* ctx, int task, int thread)
{
	(void)thread;
	const od_RangeJob* job = ctx;
	int begin = job->begin + task * job->chunk;
	int end = job->end - begin < job->chunk ? job->end : begin + job->chunk;
	job->fn(job->context, begin, end);
}

static void od_SkinRun(const od_Skin* s, int begin, int end, int chunk, double vertexNs, od_RangeFn* fn,
					   void* context)
{
	od_RangeJob job = { fn, context, begin, end, chunk };
	int tasks = (int)(((long long)end - begin + chunk - 1) / chunk);
	if (s->pool)
	{
		od_Pool_Run(s->pool, tasks, vertexNs * (end - begin), od_RunChunk, &job);
	}
	else
	{
		fn(context, begin, end);
	}
}

od_SkinDef od_DefaultSkinDef(void)
{
	od_SkinDef def;
	memset(&def, 0, sizeof def);
	def.neighbors = 4;
	return def;
}

static od_Status od_CheckSkinDef(const od_Graph* graph, const od_SkinDef* def)
{
	if (!graph)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "graph is required");
	}
	if (def->neighbors < 1 || def->neighbors > OD_MAX_SKIN)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "neighbors = %d must be in [1, %d]", def->neighbors, OD_MAX_SKIN);
	}
	od_Status status = od_Pool_CheckThreads(def->threadCount);
	return status != OD_OK ? status : od_CheckMesh(def->vertexCount, def->vertices, def->triangleCount, def->triangles, true);
}

// Area-weighted vertex normals (unit length; zero for vertices of no triangle or only degenerate ones).
static void od_TriangleNormals(const od_SkinDef* def, double* normals)
{
	memset(normals, 0, sizeof(double) * 3 * (size_t)def->vertexCount);
	for (int t = 0; t < def->triangleCount; ++t)
	{
		const int* tri = def->triangles + 3 * t;
		od_Vec3 a = od_V3Load(def->vertices + 3 * tri[0]);
		od_Vec3 n = od_Cross(od_Sub(od_V3Load(def->vertices + 3 * tri[1]), a),
							 od_Sub(od_V3Load(def->vertices + 3 * tri[2]), a));
		for (int k = 0; k < 3; ++k)
		{
			od_V3Store(normals + 3 * tri[k], od_Add(od_V3Load(normals + 3 * tri[k]), n));
		}
	}
	for (int v = 0; v < def->vertexCount; ++v)
	{
		double len = od_Length(od_V3Load(normals + 3 * v));
		if (len > 0.0)
		{
			od_V3Store(normals + 3 * v, od_Scale(1.0 / len, od_V3Load(normals + 3 * v)));
		}
	}
}

typedef struct od_BindJob
{
	od_Skin* skin;
	const od_Graph* graph;
	const od_NearestGrid* grid;
	const int* pieceSize;
	int m; // the neighbours asked (a body's vertex)
} od_BindJob;

// Each vertex blends od_SkinNeighbors of the m asked (more on a sheet); rows of vertices that blend fewer than
// s->m (the body's beside a sheet, or on a piece of fewer particles) are padded with weight 0 (on the nearest one).
static void od_BindRange(void* context, int begin, int end)
{
	od_BindJob* job = context;
	od_Skin* s = job->skin;
	double dist[OD_MAX_SKIN + 1];
	int near[OD_MAX_SKIN + 1];
	for (int v = begin; v < end; ++v)
	{
		int* idx = s->idx + (size_t)s->m * v;
		double* w = s->w + (size_t)s->m * v;
		int m = s->m > job->m ? od_SkinNeighbors(job->graph, s->rest + 3 * v, job->m) : s->m; // a sheet's, or all
		m = m < s->m ? m : s->m;
		int count = od_NearestInPiece(job->graph, job->grid, job->pieceSize, s->rest + 3 * v, m + 1, dist, near);
		for (int k = od_SumnerWeights(dist, near, count, m, idx, w); k < s->m; ++k)
		{
			idx[k] = idx[0];
			w[k] = 0.0;
		}
	}
}

od_Status od_Skin_Create(const od_Graph* graph, const od_SkinDef* def, od_Skin** out)
{
	*out = NULL;
	od_Status status = od_CheckSkinDef(graph, def);
	if (status != OD_OK)
	{
		return status;
	}
	size_t nv = (size_t)def->vertexCount;
	int asked = def->neighbors < graph->n ? def->neighbors : graph->n;
	int most = od_SkinMostNeighbors(graph, asked), m = most < graph->n ? most : graph->n;
	bool normals = def->normals || def->triangleCount > 0;
	od_Skin* s = od_AllocZero(1, sizeof *s);
	if (!s)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory binding %d vertices", def->vertexCount);
	}
	s->vertexCount = def->vertexCount;
	s->particleCount = graph->n;
	s->m = m;
	s->rest = od_Alloc(sizeof(double) * 3 * nv);
	s->restNormals = normals ? od_Alloc(sizeof(double) * 3 * nv) : NULL;
	s->idx = od_Alloc(sizeof(int) * m * nv);
	s->w = od_Alloc(sizeof(double) * m * nv);
	s->centers = od_Alloc(sizeof(double) * 3 * (size_t)graph->n);
	s->mapStore = od_Alloc(sizeof(double) * (12 * (size_t)graph->n + 3)); // malloc aligns to 8 at least
	s->maps = s->mapStore ? (double*)(((uintptr_t)s->mapStore + 31) & ~(uintptr_t)31) : NULL;
	if (od_SkinUsesAvx2())
	{
		s->columnStore = od_Alloc(sizeof(double) * (16 * (size_t)graph->n + 3));
		s->columns = s->columnStore ? (double*)(((uintptr_t)s->columnStore + 31) & ~(uintptr_t)31) : NULL;
	}
	od_NearestGrid grid = { 0 };
	int* pieceSize = od_AllocZero((size_t)graph->pieceCount, sizeof(int));
	bool threads = def->threadCount != 1 && def->vertexCount >= 2 * OD_DEFORM_CHUNK;
	if (!s->rest || (normals && !s->restNormals) || !s->idx || !s->w || !s->centers || !s->maps || !pieceSize ||
		(od_SkinUsesAvx2() && !s->columns) ||
		(threads && od_Pool_Create(def->threadCount, &s->pool) != OD_OK) ||
		od_NearestGrid_Create(&grid, graph->centers, graph->n) != OD_OK)
	{
		od_Free(pieceSize);
		od_Skin_Destroy(s);
		return od_Fail(OD_ERROR_MEMORY, "out of memory binding %d vertices", def->vertexCount);
	}
	for (int i = 0; i < graph->n; ++i)
	{
		pieceSize[graph->piece[i]]++;
	}
	memcpy(s->rest, def->vertices, sizeof(double) * 3 * nv);
	memcpy(s->centers, graph->centers, sizeof(double) * 3 * (size_t)graph->n);
	if (def->normals)
	{
		memcpy(s->restNormals, def->normals, sizeof(double) * 3 * nv);
	}
	else if (normals)
	{
		od_TriangleNormals(def, s->restNormals);
	}
	od_BindJob job = { s, graph, &grid, pieceSize, asked };
	for (int begin = 0; begin < s->vertexCount && status == OD_OK; begin += OD_BIND_BATCH)
	{
		status = od_CheckInterrupt(); // between batches, on the calling thread (workers never poll)
		int end = s->vertexCount - begin < OD_BIND_BATCH ? s->vertexCount : begin + OD_BIND_BATCH;
		if (status == OD_OK)
		{
			od_SkinRun(s, begin, end, OD_BIND_CHUNK, OD_BIND_NS, od_BindRange, &job);
		}
	}
	od_NearestGrid_Destroy(&grid);
	od_Free(pieceSize);
	if (status != OD_OK)
	{
		od_Skin_Destroy(s);
		return status;
	}
	*out = s;
	return OD_OK;
}

void od_Skin_Destroy(od_Skin* s)
{
	if (!s)
	{
		return;
	}
	od_Free(s->rest);
	od_Free(s->restNormals);
	od_Free(s->idx);
	od_Free(s->w);
	od_Free(s->centers);
	od_Free(s->mapStore);
	od_Free(s->columnStore);
	od_Pool_Destroy(s->pool);
	od_Free(s);
}

int od_Skin_GetVertexCount(const od_Skin* s)
{
	return s->vertexCount;
}

int od_Skin_GetParticleCount(const od_Skin* s)
{
	return s->particleCount;
}

int od_Skin_GetNeighborCount(const od_Skin* s)
{
	return s->m;
}

const int* od_Skin_GetIndices(const od_Skin* s)
{
	return s->idx;
}

const double* od_Skin_GetWeights(const od_Skin* s)
{
	return s->w;
}

const double* od_Skin_GetRestNormals(const od_Skin* s)
{
	return s->restNormals;
}

// od_Skin_DeformShown's arrays: each block of the skin is the reference of od_ShownOffset, never stored.
typedef struct od_ShownJob
{
	const double* skinned;
	const double* lock;
	const float* input;
	float* offset;
	float* out;
} od_ShownJob;

typedef struct od_DeformJob
{
	const od_Skin* skin;
	const double* maps; // particleCount*12, rows [R | x - R X̄]
	const od_SkinTarget* target;
	const void* restNormals;
	od_Scalar restNormalType;
	const od_ShownJob* shown; // NULL: the positions go to the target
} od_DeformJob;

#if (defined(__GNUC__) || defined(__clang__)) && !defined(OD_NO_VECTOR_EXTENSIONS)
// The blend's 12 accumulators as six pairs, two doubles in one register (GCC and Clang vector extensions: SSE2
// on x86-64, NEON on arm64): a third faster than 12 scalars, which the compiler vectorizes poorly.
typedef double od_Pair __attribute__((vector_size(16)));
#define OD_BLEND_INLINE static inline __attribute__((always_inline))
#define OD_BLEND_ZERO(a) od_Pair a[6] = { { 0, 0 }, { 0, 0 }, { 0, 0 }, { 0, 0 }, { 0, 0 }, { 0, 0 } }
#define OD_BLEND_ADD(a, weight, map12)                                                                 \
	do                                                                                                 \
	{                                                                                                  \
		const od_Pair* pairs_ = (const od_Pair*)__builtin_assume_aligned((map12), 16);                 \
		od_Pair w_ = { (weight), (weight) };                                                           \
		for (int e_ = 0; e_ < 6; ++e_)                                                                 \
		{                                                                                              \
			(a)[e_] += w_ * pairs_[e_];                                                                \
		}                                                                                              \
	} while (0)
#define OD_BLEND_LANE(a, i) ((a)[(i) / 2][(i) % 2])
#else
// Portable fallback (MSVC, or -DOD_NO_VECTOR_EXTENSIONS): 12 scalars, the same operations in the same order,
// so the results are identical bit for bit.
#define OD_BLEND_INLINE static inline
#define OD_BLEND_ZERO(a) double a[12] = { 0 }
#define OD_BLEND_ADD(a, weight, map12)                                                                 \
	for (int e_ = 0; e_ < 12; ++e_)                                                                    \
	{                                                                                                  \
		(a)[e_] += (weight) * (map12)[e_];                                                             \
	}
#define OD_BLEND_LANE(a, i) ((a)[i])
#endif

// Vertices are blended in blocks into double buffers on the stack, then stored in the target's types, so
// that the blend has no per-vertex branch on types.
#define OD_SKIN_BLOCK 256

// Positions p and (when rn is not NULL) normals q, not yet normalized, of the count vertices from `first`,
// as doubles; m is a compile-time constant where the caller passes one, so that the blend unrolls.
OD_BLEND_INLINE void od_BlendBlock(const od_Skin* s, const double* maps, size_t first,
																int count, int m, const double* rn, double* p,
																double* q)
{
	const int* idx = s->idx + (size_t)m * first;
	const double* w = s->w + (size_t)m * first;
	const double* rest = s->rest + 3 * first;
	for (int v = 0; v < count; ++v)
	{
		OD_BLEND_ZERO(a);
		for (int k = 0; k < m; ++k)
		{
			OD_BLEND_ADD(a, w[m * v + k], maps + 12 * idx[m * v + k]);
		}
		const double* x = rest + 3 * v;
		for (int r = 0; r < 3; ++r)
		{
			p[3 * v + r] = OD_BLEND_LANE(a, 4 * r) * x[0] + OD_BLEND_LANE(a, 4 * r + 1) * x[1] +
						   OD_BLEND_LANE(a, 4 * r + 2) * x[2] + OD_BLEND_LANE(a, 4 * r + 3);
		}
		if (rn)
		{
			const double* n = rn + 3 * v;
			for (int r = 0; r < 3; ++r)
			{
				q[3 * v + r] = OD_BLEND_LANE(a, 4 * r) * n[0] + OD_BLEND_LANE(a, 4 * r + 1) * n[1] +
							   OD_BLEND_LANE(a, 4 * r + 2) * n[2];
			}
		}
	}
}

#ifdef OD_SKIN_AVX2
// od_BlendBlock with AVX2 + FMA: each particle's map as 4 columns of 4 doubles (the 4th lane 0), so that the
// blend is 4 m fused multiply-adds and the position C0 x + C1 y + C2 z + C3 three more, with no horizontal sum;
// m a compile-time constant where the caller passes one (4, the default; 6, docs/goals.md's remedy for skin seams:
// 2.2x slower at 1M vertices in od_BlendBlock's loop, `scripts/bench skin --neighbors 6`). p and q get a 4th lane past each
// vertex's 3 (overwritten by the next vertex; the buffers have one double to spare). Fused multiply-adds round
// once where the SSE2 blend rounds twice: the results differ from it in the last bits (about 1e-16 relative),
// never between threads (the first term's fused add to zero is the plain product, as before m was general).
__attribute__((target("avx2,fma"))) static inline void od_BlendBlockAvx2(const od_Skin* s, const double* columns,
																	size_t first, int count, int m,
																	const double* rn, double* p, double* q)
{
	const int* idx = s->idx + (size_t)m * first;
	const double* w = s->w + (size_t)m * first;
	const double* rest = s->rest + 3 * first;
	for (int v = 0; v < count; ++v)
	{
		// the streams a few vertices ahead: measured 10 % faster at 1M vertices than the hardware prefetcher alone
		_mm_prefetch((const char*)(w + m * (v + OD_SKIN_PREFETCH)), _MM_HINT_T0);
		_mm_prefetch((const char*)(idx + m * (v + OD_SKIN_PREFETCH)), _MM_HINT_T0);
		_mm_prefetch((const char*)(rest + 3 * (v + OD_SKIN_PREFETCH)), _MM_HINT_T0);
		if (rn)
		{
			_mm_prefetch((const char*)(rn + 3 * (v + OD_SKIN_PREFETCH)), _MM_HINT_T0);
		}
		__m256d c[4] = { _mm256_setzero_pd(), _mm256_setzero_pd(), _mm256_setzero_pd(), _mm256_setzero_pd() };
		for (int k = 0; k < m; ++k)
		{
			const double* map = columns + 16 * idx[m * v + k];
			__m256d wk = _mm256_broadcast_sd(w + m * v + k);
			for (int e = 0; e < 4; ++e)
			{
				c[e] = _mm256_fmadd_pd(wk, _mm256_load_pd(map + 4 * e), c[e]);
			}
		}
		const double* x = rest + 3 * v;
		__m256d pv = _mm256_fmadd_pd(c[0], _mm256_broadcast_sd(x),
									 _mm256_fmadd_pd(c[1], _mm256_broadcast_sd(x + 1),
													 _mm256_fmadd_pd(c[2], _mm256_broadcast_sd(x + 2), c[3])));
		_mm256_storeu_pd(p + 3 * v, pv);
		if (rn)
		{
			const double* n = rn + 3 * v;
			__m256d qv = _mm256_fmadd_pd(c[0], _mm256_broadcast_sd(n),
										 _mm256_fmadd_pd(c[1], _mm256_broadcast_sd(n + 1),
														 _mm256_mul_pd(c[2], _mm256_broadcast_sd(n + 2))));
			_mm256_storeu_pd(q + 3 * v, qv);
		}
	}
}
#endif

// Scales count 3-vectors to unit length (zero ones stay zero), in passes the compiler vectorizes so that
// square roots and divisions of neighbouring vertices overlap.
OD_BLEND_INLINE void od_NormalizeBlock(double* q, int count)
{
	double scale[OD_SKIN_BLOCK];
	for (int v = 0; v < count; ++v)
	{
		scale[v] = q[3 * v] * q[3 * v] + q[3 * v + 1] * q[3 * v + 1] + q[3 * v + 2] * q[3 * v + 2];
	}
	for (int v = 0; v < count; ++v)
	{
		scale[v] = 1.0 / sqrt(scale[v] + DBL_MIN); // no branch; a zero vector times a finite scale stays zero
	}
	for (int v = 0; v < count; ++v)
	{
		q[3 * v] *= scale[v];
		q[3 * v + 1] *= scale[v];
		q[3 * v + 2] *= scale[v];
	}
}

// Copies count doubles into base (of the given type) from item `first` on.
OD_BLEND_INLINE void od_StoreBlock(void* base, od_Scalar type, size_t first, const double* src, int count)
{
	if (type == OD_FLOAT32)
	{
		float* f = (float*)base + first;
		for (int k = 0; k < count; ++k)
		{
			f[k] = (float)src[k];
		}
	}
	else
	{
		memcpy((double*)base + first, src, sizeof(double) * (size_t)count);
	}
}

#ifdef OD_SKIN_AVX2
// od_StoreBlock for float32 with streaming (non-temporal) stores: a large mesh's outputs go to memory without
// being read into the cache first (a third less traffic for what is written). Same conversion, same values.
// Used for meshes of OD_STREAM_VERTICES and more, whose outputs do not stay in the cache anyway.
__attribute__((target("avx2,fma"))) static inline void od_StreamFloats(void* base, size_t first, const double* src,
																		 int count)
{
	float* f = (float*)base + first;
	int k = 0;
	if (((uintptr_t)f & 15) == 0)
	{
		for (; k + 8 <= count; k += 8)
		{
			_mm_stream_ps(f + k, _mm256_cvtpd_ps(_mm256_loadu_pd(src + k)));
			_mm_stream_ps(f + k + 4, _mm256_cvtpd_ps(_mm256_loadu_pd(src + k + 4)));
		}
	}
	for (; k < count; ++k)
	{
		f[k] = (float)src[k];
	}
}
#endif

// A block of outputs, 3 values a vertex from vertex `first`: streamed where asked (float32 only), else stored.
OD_BLEND_INLINE void od_WriteBlock(void* base, od_Scalar type, bool stream, int first, const double* src, int count)
{
#ifdef OD_SKIN_AVX2
	if (stream && type == OD_FLOAT32)
	{
		od_StreamFloats(base, 3 * (size_t)first, src, 3 * count);
		return;
	}
#endif
	(void)stream;
	od_StoreBlock(base, type, 3 * (size_t)first, src, 3 * count);
}

// A block's blend, m maps a vertex: AVX2 where avx, else the baseline.
OD_BLEND_INLINE void od_Blend(const od_DeformJob* job, size_t first, int count, int m, bool avx, const double* rn,
							  double* p, double* q)
{
	if (avx)
	{
#ifdef OD_SKIN_AVX2
		od_BlendBlockAvx2(job->skin, job->skin->columns, first, count, m, rn, p, q);
#endif
	}
	else
	{
		od_BlendBlock(job->skin, job->maps, first, count, m, rn, p, q);
	}
}

// The vertex loop; avx (a constant where inlined) picks the AVX2 blend. Inlined twice: into od_DeformRange
// (the baseline) and od_DeformRangeAvx2, where the compiler vectorizes the conversions, the normalization
// (square roots and divisions, exact in IEEE arithmetic: the same normals from the same q) and the float32
// stores 4 wide.
OD_BLEND_INLINE void od_DeformRangeBody(void* context, int begin, int end, bool avx)
{
	const od_DeformJob* job = context;
	const od_Skin* s = job->skin;
	const od_SkinTarget* t = job->target;
	double p[3 * OD_SKIN_BLOCK + 1], q[3 * OD_SKIN_BLOCK + 1], n[3 * OD_SKIN_BLOCK]; // + 1: the AVX2 4th lane
	for (int first = begin; first < end; first += OD_SKIN_BLOCK)
	{
		int count = end - first < OD_SKIN_BLOCK ? end - first : OD_SKIN_BLOCK;
		const double* rn = NULL;
		if (t->normals && job->restNormalType == OD_FLOAT32)
		{
			const float* f = (const float*)job->restNormals + 3 * (size_t)first;
			for (int k = 0; k < 3 * count; ++k)
			{
				n[k] = f[k];
			}
			rn = n;
		}
		else if (t->normals)
		{
			rn = (const double*)job->restNormals + 3 * (size_t)first;
		}
		if (s->m == 4) // the default and the skin seams' 6 as compile-time constants: the blend unrolls
		{
			od_Blend(job, (size_t)first, count, 4, avx, rn, p, q);
		}
		else if (s->m == 6)
		{
			od_Blend(job, (size_t)first, count, 6, avx, rn, p, q);
		}
		else
		{
			od_Blend(job, (size_t)first, count, s->m, avx, rn, p, q);
		}
		bool stream = avx && s->vertexCount >= OD_STREAM_VERTICES;
		const od_ShownJob* shown = job->shown;
		if (shown)
		{
			size_t at = 3 * (size_t)first;
			od_ShownOffset(count, shown->skinned + at, p, shown->lock ? shown->lock + at : NULL, shown->input + at,
						   shown->offset + at, shown->out + at);
			continue;
		}
		od_WriteBlock(t->positions, t->positionType, stream, first, p, count);
		if (rn)
		{
			od_NormalizeBlock(q, count);
			od_WriteBlock(t->normals, t->normalType, stream, first, q, count);
		}
	}
#ifdef OD_SKIN_AVX2
	if (avx && s->vertexCount >= OD_STREAM_VERTICES)
	{
		_mm_sfence(); // the streamed stores are seen by the thread that waits for this chunk
	}
#endif
}

static void od_DeformRange(void* context, int begin, int end)
{
	od_DeformRangeBody(context, begin, end, false);
}

#ifdef OD_SKIN_AVX2
__attribute__((target("avx2,fma"))) static void od_DeformRangeAvx2(void* context, int begin, int end)
{
	od_DeformRangeBody(context, begin, end, true);
}
#endif

// Each particle's rigid motion as its 3x4 map (and, for the AVX2 blend, its 4 columns) in the skin's buffers.
static void od_SkinMaps(const od_Skin* s, const double* positions, const double* rotations)
{
	double* maps = s->maps; // a deform allocates nothing (one call at a time per skin, like the pool)
	for (int j = 0; j < s->particleCount; ++j)
	{
		od_Mat3 r = od_M3Load(rotations + 9 * j);
		od_Vec3 x = od_Sub(od_V3Load(positions + 3 * j), od_M3MulV(&r, od_V3Load(s->centers + 3 * j)));
		double* map = maps + 12 * j;
		for (int row = 0; row < 3; ++row)
		{
			memcpy(map + 4 * row, r.m + 3 * row, sizeof(double) * 3);
		}
		map[3] = x.x;
		map[7] = x.y;
		map[11] = x.z;
		if (s->columns)
		{
			double* col = s->columns + 16 * j; // column c: (map[c], map[4 + c], map[8 + c], 0)
			for (int c = 0; c < 4; ++c)
			{
				col[4 * c] = map[c];
				col[4 * c + 1] = map[4 + c];
				col[4 * c + 2] = map[8 + c];
				col[4 * c + 3] = 0.0;
			}
		}
	}
}

// The vertex loop of a job over the skin's vertices (the AVX2 blend where the skin has its columns).
static void od_SkinRunJob(const od_Skin* s, od_DeformJob* job)
{
#ifdef OD_SKIN_AVX2
	od_SkinRun(s, 0, s->vertexCount, OD_DEFORM_CHUNK, OD_DEFORM_NS, s->columns ? od_DeformRangeAvx2 : od_DeformRange,
			   job);
#else
	od_SkinRun(s, 0, s->vertexCount, OD_DEFORM_CHUNK, OD_DEFORM_NS, od_DeformRange, job);
#endif
}

od_Status od_Skin_Deform(const od_Skin* s, const double* positions, const double* rotations,
						 const od_SkinTarget* target)
{
	if (!positions || !rotations || !target || !target->positions)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "positions, rotations and an output buffer are required");
	}
	const void* restNormals = target->restNormals ? target->restNormals : s->restNormals;
	od_Scalar restNormalType = target->restNormals ? target->restNormalType : OD_FLOAT64;
	if (target->normals && !restNormals)
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "normals: give rest normals, or triangles or normals when binding, to get deformed normals");
	}
	od_SkinMaps(s, positions, rotations);
	od_DeformJob job = { s, s->maps, target, restNormals, restNormalType, NULL };
	od_SkinRunJob(s, &job);
	return OD_OK;
}

void od_ShownOffset(int count, const double* skinned, const double* reference, const double* lock,
					const float* input, float* offset, float* out)
{
	for (size_t k = 0; k < 3 * (size_t)count; ++k)
	{
		double d = skinned[k] - reference[k];
		float f = (float)(lock ? d * lock[k] : d);
		offset[k] = f;
		out[k] = input[k] + f;
	}
}

od_Status od_Skin_DeformShown(const od_Skin* s, const double* positions, const double* rotations,
							  const double* skinned, const double* lock, const float* input, float* offset, float* out)
{
	if (!positions || !rotations || !skinned || !input || !offset || !out)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "positions, rotations, skinned, input, offset and out are required");
	}
	od_SkinMaps(s, positions, rotations);
	od_SkinTarget none;
	memset(&none, 0, sizeof none);
	od_ShownJob shown = { skinned, lock, input, offset, out };
	od_DeformJob job = { s, s->maps, &none, NULL, OD_FLOAT64, &shown };
	od_SkinRunJob(s, &job);
	return OD_OK;
}

// The local step's AVX2 kernel: one particle's sum C_i with the rows of its 3x3 matrices in 256-bit registers.
//
// Design: the sweep is Gauss-Seidel in index order (local_step.c), so particle i+1 reads the rotation particle i
// has just written; four consecutive particles at once would be another sweep, not the same one rounded
// differently (docs/speed.md has the figures). The vector width goes into one particle's update instead. Row r
// of C_i gets, per edge e to particle j, Σ_k R_j[r][k] M_e[k][·] + d_r a_eᵀ: a broadcast element of R_j times a
// row of M_e, four lanes a row (the fourth zero). The products and the order of the additions are the scalar
// loop's, with no fused multiply-add, so C_i is bit-identical to it and the results do not depend on the
// processor. The polar decomposition stays scalar: an AVX2 + FMA Newton step was 0.73x the scalar one's time on
// independent matrices but no faster inside the sweep, where each update waits for the one before.
// Compiled for x86-64 only, with target attributes (the build targets the baseline), like skinning.c's blend.
#include "local_avx2.h"

#ifdef OD_LOCAL_AVX2
#include <immintrin.h>

#define OD_AVX2 __attribute__((target("avx2"))) // no fused multiply-add: the scalar rounding

// The first three doubles of p in lanes 0-2, lane 3 zero: the last rows end their arrays.
OD_AVX2 static inline __m256d od_Load3(const double* p)
{
	return _mm256_maskload_pd(p, _mm256_set_epi64x(0, -1, -1, -1));
}

// Row r of R_j M_e + d_r a_eᵀ, summed as the scalar loop sums it: ((r0 m0 + r1 m1) + r2 m2) + d a.
OD_AVX2 static inline __m256d od_EdgeRow(const double* rj, __m256d m0, __m256d m1, __m256d m2, double d, __m256d a)
{
	__m256d t = _mm256_mul_pd(_mm256_broadcast_sd(rj), m0);
	t = _mm256_add_pd(t, _mm256_mul_pd(_mm256_broadcast_sd(rj + 1), m1));
	t = _mm256_add_pd(t, _mm256_mul_pd(_mm256_broadcast_sd(rj + 2), m2));
	return _mm256_add_pd(t, _mm256_mul_pd(_mm256_set1_pd(d), a));
}

OD_AVX2 void od_LocalAvx2_Sum(const od_Sim* sim, int i, double c[9])
{
	const od_Graph* g = sim->graph;
	const double* x = sim->state.x;
	const double* rot = sim->state.R;
	double xi0 = x[3 * i], xi1 = x[3 * i + 1], xi2 = x[3 * i + 2];
	__m256d s0 = _mm256_setzero_pd(), s1 = s0, s2 = s0;
	for (int e = g->adjStart[i]; e < g->adjStart[i + 1]; ++e)
	{
		int j = g->adj[e];
		const double* rj = rot + 9 * j;
		const double* m = sim->edgeMoment + 9 * e;
		__m256d m0 = _mm256_loadu_pd(m), m1 = _mm256_loadu_pd(m + 3), m2 = od_Load3(m + 6);
		__m256d a = od_Load3(sim->edgeArm + 3 * e);
		s0 = _mm256_add_pd(s0, od_EdgeRow(rj, m0, m1, m2, x[3 * j] - xi0, a));
		s1 = _mm256_add_pd(s1, od_EdgeRow(rj + 3, m0, m1, m2, x[3 * j + 1] - xi1, a));
		s2 = _mm256_add_pd(s2, od_EdgeRow(rj + 6, m0, m1, m2, x[3 * j + 2] - xi2, a));
	}
	if (sim->mode == OD_DYNAMIC) // + the inertia's term, added after the edges as the scalar path adds it
	{
		const double* t = sim->inertiaTerm + 9 * i;
		s0 = _mm256_add_pd(s0, _mm256_loadu_pd(t));
		s1 = _mm256_add_pd(s1, _mm256_loadu_pd(t + 3));
		s2 = _mm256_add_pd(s2, od_Load3(t + 6));
	}
	// Lane 3 lands on c[3], then on c[6], each overwritten by the next row; the last row in two plain stores:
	// the caller reads c at once, and a masked store does not forward to loads.
	_mm256_storeu_pd(c, s0);
	_mm256_storeu_pd(c + 3, s1);
	_mm_storeu_pd(c + 6, _mm256_castpd256_pd128(s2));
	_mm_store_sd(c + 8, _mm256_extractf128_pd(s2, 1));
}
#endif

// The local step's AVX2 kernels: one particle's sum C_i with the rows of its 3x3 matrices in 256-bit registers, and
// a batch of two to four particles whose polar decompositions run in the lanes.
//
// Design. The sum: row r of C_i gets, per edge e to particle j, Σ_k R_j[r][k] M_e[k][·] + d_r a_eᵀ: a broadcast
// element of R_j times a row of M_e, four lanes a row (the fourth zero). The batch: the sweep is Gauss-Seidel, so
// particle i+1 mostly reads the rotation particle i has just written, and four consecutive particles at once
// would be another sweep; local_step.c's schedule instead gathers particles none of which reads another, taken
// out of order only where that changes nothing (docs/speed.md has the figures). Each member's rows are summed as
// above, transposed so that a register holds one element of the four matrices, and od_PolarRotationWarm runs in
// the lanes: its Newton steps with the same operations in the same order, a lane leaving when its step converges
// or its H is not clearly positive definite (that lane then takes the scalar SVD, as the scalar code does). The
// four chains of dependent divisions overlap, where one particle's waited on the one before.
// Everywhere the products and the order of the additions are the scalar code's, with no fused multiply-add (the
// kernels are compiled for "avx2" alone), so the results are bit-identical to it and do not depend on the
// processor. Compiled for x86-64 only, with target attributes (the build targets the baseline), like skinning.c's
// blend.
#include "local_avx2.h"

#ifdef OD_LOCAL_AVX2
#include "polar.h"

#include <immintrin.h>
#include <string.h>

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

// The rows of C_i's edge and inertia part (od_LocalAvx2_Sum), lane 3 of each not part of it.
OD_AVX2 static inline void od_SumRows(const od_Sim* sim, int i, __m256d s[3])
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
	s[0] = s0, s[1] = s1, s[2] = s2;
}

OD_AVX2 void od_LocalAvx2_Sum(const od_Sim* sim, int i, double c[9])
{
	__m256d s[3];
	od_SumRows(sim, i, s);
	// Lane 3 lands on c[3], then on c[6], each overwritten by the next row; the last row in two plain stores:
	// the caller reads c at once, and a masked store does not forward to loads.
	_mm256_storeu_pd(c, s[0]);
	_mm256_storeu_pd(c + 3, s[1]);
	_mm_storeu_pd(c + 6, _mm256_castpd256_pd128(s[2]));
	_mm_store_sd(c + 8, _mm256_extractf128_pd(s[2], 1));
}

// Four 3x3 matrices, one a lane: m[k] holds element k (row-major, as od_Mat3) of each.
typedef struct od_Mat3x4
{
	__m256d m[9];
} od_Mat3x4;

// od_M3Mul in the lanes: a b, each element ((·) + (·)) + (·) as there.
OD_AVX2 static inline od_Mat3x4 od_Mul4(const od_Mat3x4* a, const od_Mat3x4* b)
{
	od_Mat3x4 c;
	for (int r = 0; r < 3; ++r)
	{
		for (int k = 0; k < 3; ++k)
		{
			c.m[3 * r + k] = a->m[3 * r] * b->m[k] + a->m[3 * r + 1] * b->m[3 + k] + a->m[3 * r + 2] * b->m[6 + k];
		}
	}
	return c;
}

// od_M3MulTN in the lanes: aᵀ b.
OD_AVX2 static inline od_Mat3x4 od_MulTN4(const od_Mat3x4* a, const od_Mat3x4* b)
{
	od_Mat3x4 c;
	for (int r = 0; r < 3; ++r)
	{
		for (int k = 0; k < 3; ++k)
		{
			c.m[3 * r + k] = a->m[r] * b->m[k] + a->m[3 + r] * b->m[3 + k] + a->m[6 + r] * b->m[6 + k];
		}
	}
	return c;
}

OD_AVX2 static inline __m256d od_Greater(__m256d a, __m256d b)
{
	return _mm256_cmp_pd(a, b, _CMP_GT_OQ); // false where either is NaN, as a > b
}

// polar.c's od_SolveSpd3 in the lanes: x = h⁻¹ b by the adjugate; returns the lanes where h is clearly positive
// definite (x is meaningless in the others).
OD_AVX2 static inline __m256d od_SolveSpd4(const __m256d h[9], const __m256d b[3], __m256d tiny, __m256d x[3])
{
	__m256d c00 = h[4] * h[8] - h[5] * h[7], c01 = h[2] * h[7] - h[1] * h[8], c02 = h[1] * h[5] - h[2] * h[4];
	__m256d minor2 = h[0] * h[4] - h[1] * h[3];
	__m256d det = h[0] * c00 + h[3] * c01 + h[6] * c02;
	__m256d ok = _mm256_and_pd(od_Greater(h[0], tiny), od_Greater(minor2, tiny * h[0]));
	ok = _mm256_and_pd(ok, od_Greater(det, tiny * minor2));
	__m256d c11 = h[0] * h[8] - h[2] * h[6], c12 = h[2] * h[3] - h[0] * h[5], c22 = minor2;
	__m256d inv = _mm256_set1_pd(1.0) / det;
	x[0] = inv * (c00 * b[0] + c01 * b[1] + c02 * b[2]);
	x[1] = inv * (c01 * b[0] + c11 * b[1] + c12 * b[2]);
	x[2] = inv * (c02 * b[0] + c12 * b[1] + c22 * b[2]);
	return ok;
}

// polar.c's od_Cayley in the lanes: I + f K + f K² with K = [a]x, a = w/2, f = 2 / (1 + a·a). od_M3SkewSeries
// forms K² by od_M3Mul, with K's zeros; here K² = a aᵀ - |a|² I by its nonzero products alone, in the same order
// ((-a2)(a2) + a1(-a1) is -a2² - a1²). Dropping a product with a zero of K changes at most the sign of a zero
// entry of K² (w finite: a finite, f in [0, 2]), and no entry of the result: the diagonal is 1 + f K²_jj, an
// entry off it (0 + f K_j) + f K²_j, and adding ±0 to 1 or to that sum, +0 if zero, gives the same bits. Where w
// is not finite the result holds a NaN either way (f K_j = 0 · ∞), and so the lane's next step fails (its H
// has a NaN): the SVD, whatever the Cayley rotation was.
OD_AVX2 static inline od_Mat3x4 od_Cayley4(const __m256d w[3])
{
	__m256d half = _mm256_set1_pd(0.5), zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
	__m256d a0 = half * w[0], a1 = half * w[1], a2 = half * w[2];
	__m256d s0 = a0 * a0, s1 = a1 * a1, s2 = a2 * a2;
	__m256d f = _mm256_set1_pd(2.0) / (one + (s0 + s1 + s2));
	__m256d f0 = f * a0, f1 = f * a1, f2 = f * a2;         // f K's entries, up to sign
	__m256d g01 = f * (a1 * a0), g02 = f * (a2 * a0), g12 = f * (a2 * a1); // f K²'s, off the diagonal
	od_Mat3x4 r = { { one + f * (-s2 - s1), (zero + -f2) + g01, (zero + f1) + g02, (zero + f2) + g01,
					  one + f * (-s2 - s0), (zero + -f0) + g12, (zero + -f1) + g02, (zero + f0) + g12,
					  one + f * (-s1 - s0) } };
	return r;
}

// One Newton step of od_PolarRotationWarm in the lanes of `active`: rr <- rr E(w) where the step's H is clearly
// positive definite; returns those lanes, and w·w in *ww.
OD_AVX2 static inline __m256d od_NewtonStep4(od_Mat3x4* rr, const od_Mat3x4* a, __m256d tiny, __m256d active,
											 __m256d* ww)
{
	od_Mat3x4 m = od_MulTN4(rr, a);
	__m256d ax[3] = { m.m[7] - m.m[5], m.m[2] - m.m[6], m.m[3] - m.m[1] };
	__m256d tr = m.m[0] + m.m[4] + m.m[8], neg = _mm256_set1_pd(-0.5);
	__m256d h01 = neg * (m.m[1] + m.m[3]), h02 = neg * (m.m[2] + m.m[6]), h12 = neg * (m.m[5] + m.m[7]);
	__m256d h[9] = { tr - m.m[0], h01, h02, h01, tr - m.m[4], h12, h02, h12, tr - m.m[8] };
	__m256d w[3];
	__m256d ok = _mm256_and_pd(active, od_SolveSpd4(h, ax, tiny, w));
	od_Mat3x4 e = od_Cayley4(w);
	od_Mat3x4 next = od_Mul4(rr, &e);
	for (int j = 0; j < 9; ++j)
	{
		rr->m[j] = _mm256_blendv_pd(rr->m[j], next.m[j], ok);
	}
	*ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
	return ok;
}

// The 4x4 transpose: lane l of out[k] is lane k of in[l].
OD_AVX2 static inline void od_Transpose4(const __m256d in[4], __m256d out[4])
{
	__m256d t0 = _mm256_unpacklo_pd(in[0], in[1]), t1 = _mm256_unpackhi_pd(in[0], in[1]);
	__m256d t2 = _mm256_unpacklo_pd(in[2], in[3]), t3 = _mm256_unpackhi_pd(in[2], in[3]);
	out[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
	out[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
	out[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
	out[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
}

// The batch's matrices C_i (od_LocalMatrix's: the sum, then the goals' term as od_Goals_AddLocal adds it) and
// warm starts into lanes; a lane past count repeats the first particle's.
OD_AVX2 static inline void od_Gather4(const od_Sim* sim, const int* members, int count, od_Mat3x4* a, od_Mat3x4* rr)
{
	__m256d rows[3][OD_LOCAL_LANES], wide[OD_LOCAL_LANES];
	const double* r[OD_LOCAL_LANES];
	for (int k = 0; k < count; ++k)
	{
		int i = members[k];
		r[k] = sim->state.R + 9 * i;
		__m256d s[3];
		od_SumRows(sim, i, s);
		for (int row = 0; row < 3; ++row)
		{
			rows[row][k] = s[row];
			if (sim->goals.omega2)
			{
				rows[row][k] = rows[row][k] + od_Load3(sim->goals.term + 9 * i + 3 * row);
			}
		}
	}
	for (int k = count; k < OD_LOCAL_LANES; ++k)
	{
		r[k] = r[0];
		rows[0][k] = rows[0][0], rows[1][k] = rows[1][0], rows[2][k] = rows[2][0];
	}
	for (int row = 0; row < 3; ++row)
	{
		od_Transpose4(rows[row], wide);
		a->m[3 * row] = wide[0], a->m[3 * row + 1] = wide[1], a->m[3 * row + 2] = wide[2];
	}
	for (int half = 0; half < 2; ++half)
	{
		for (int k = 0; k < OD_LOCAL_LANES; ++k)
		{
			wide[k] = _mm256_loadu_pd(r[k] + 4 * half);
		}
		od_Transpose4(wide, rr->m + 4 * half);
	}
	rr->m[8] = _mm256_set_pd(r[3][8], r[2][8], r[1][8], r[0][8]);
}

OD_AVX2 static inline void od_Scatter4(const od_Mat3x4* rr, double* const* r, int count)
{
	__m256d rows[2][OD_LOCAL_LANES];
	od_Transpose4(rr->m, rows[0]);
	od_Transpose4(rr->m + 4, rows[1]);
	double last[OD_LOCAL_LANES];
	_mm256_storeu_pd(last, rr->m[8]);
	for (int k = 0; k < count; ++k)
	{
		_mm256_storeu_pd(r[k], rows[0][k]);
		_mm256_storeu_pd(r[k] + 4, rows[1][k]);
		r[k][8] = last[k];
	}
}

// Lane k of a as an od_Mat3.
OD_AVX2 static inline od_Mat3 od_Lane(const od_Mat3x4* a, int k)
{
	double lanes[9][OD_LOCAL_LANES];
	od_Mat3 out;
	for (int j = 0; j < 9; ++j)
	{
		_mm256_storeu_pd(lanes[j], a->m[j]);
		out.m[j] = lanes[j][k];
	}
	return out;
}

OD_AVX2 int od_LocalAvx2_Batch(od_Sim* sim, const int* members, int count)
{
	od_Mat3x4 a, rr;
	od_Gather4(sim, members, count, &a, &rr);
	__m256d zero = _mm256_setzero_pd(), norm2 = zero;
	for (int k = 0; k < 9; ++k)
	{
		norm2 = norm2 + a.m[k] * a.m[k];
	}
	__m256d tiny = _mm256_set1_pd(1e-10) * _mm256_sqrt_pd(norm2);
	// A zero matrix keeps its warm start; a lane leaves when its step converges or its H is not clearly positive
	// definite (failed: the SVD below), as the scalar loop returns or breaks.
	__m256d active = _mm256_cmp_pd(norm2, zero, _CMP_NEQ_UQ), failed = zero;
	for (int it = 0; it < 8 && _mm256_movemask_pd(active); ++it)
	{
		__m256d ww, ok = od_NewtonStep4(&rr, &a, tiny, active, &ww);
		failed = _mm256_or_pd(failed, _mm256_andnot_pd(ok, active));
		active = _mm256_andnot_pd(_mm256_cmp_pd(ww, _mm256_set1_pd(1e-6), _CMP_LT_OQ), ok);
	}
	int fell = _mm256_movemask_pd(_mm256_or_pd(failed, active)), fallbacks = 0; // active: 8 steps, no convergence
	double* r[OD_LOCAL_LANES];
	for (int k = 0; k < count; ++k)
	{
		r[k] = sim->state.R + 9 * members[k];
	}
	od_Scatter4(&rr, r, count);
	for (int k = 0; k < count; ++k)
	{
		if (fell >> k & 1)
		{
			od_Mat3 c = od_Lane(&a, k), p = od_PolarRotation(&c);
			memcpy(r[k], p.m, sizeof p.m);
			++fallbacks;
		}
	}
	return fallbacks;
}
#endif

// od_Svd3 for many matrices, four at a time in AVX2 registers where the processor has them.
//
// Design: each of the four lanes of a 256-bit register holds one matrix, and every lane runs od_Svd3's own
// arithmetic (polar.c): the same IEEE operations (+, −, ×, ÷, √ are correctly rounded, in a lane as in a scalar
// register) in the same order, with no fused multiply-add (the kernel is compiled for "avx2" alone, so the
// compiler cannot contract a product and a sum), so each lane's U, Σ, V are od_Svd3's, bit for bit. Where od_Svd3
// branches, the lanes take masks and blends instead:
// - Jacobi: a lane stops sweeping when od_Svd3 would have (off-diagonal mass ≤ 1e-36 of the diagonal's, or
//   zero), and skips a rotation whose pivot is zero, by keeping its old values; the sweeps go on while any lane
//   is active (od_Svd3's limit of 32), which for the snow's F is 3 to 5;
// - the eigenvalue sort is its three compare-and-swaps, each a blend of the values and columns of V; the sign of
//   det(V) flips V's last column by a masked sign bit;
// - a Givens rotation with r = 0 keeps its lane; where r² under- or overflows, that lane's r is od_Svd3's hypot,
//   computed for that lane alone (a rare branch, never taken for a deformation gradient of sane size).
// Identical results mean the MPM trajectories do not depend on which path ran (tests/test_svd4.py). The
// 4-wide path is compiled on x86-64 with GCC or Clang only and runs where od_Platform_HasAvx2Fma (platform.c:
// processor, operating system, OPDEFORM_NO_AVX2); elsewhere, and for the last count % 4, the matrices go
// through od_Svd3 one by one.
#include "platform.h"
#include "polar.h"

#include <float.h>

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__) && !defined(OD_NO_VECTOR_EXTENSIONS)
#define OD_SVD4 1
#include <immintrin.h>
#endif

#ifdef OD_SVD4
#define OD_SVD4_FN __attribute__((target("avx2"))) static inline
#define OD_SVD4_KERNEL __attribute__((target("avx2"))) static

// mask ? yes : no, lane by lane (a mask lane is all ones or all zeros)
OD_SVD4_FN __m256d od_Pick(__m256d mask, __m256d yes, __m256d no)
{
	return _mm256_blendv_pd(no, yes, mask);
}

OD_SVD4_FN bool od_AnyLane(__m256d mask)
{
	return _mm256_movemask_pd(mask) != 0;
}

// One Jacobi rotation in the (p, q) plane of the symmetric e (both triangles kept), for the lanes of `active`
// whose pivot e[p][q] is not zero: od_Jacobi3's loop body.
OD_SVD4_FN void od_Rotate4(__m256d e[3][3], __m256d v[3][3], int p, int q, __m256d active)
{
	__m256d apq = e[p][q];
	__m256d on = _mm256_and_pd(active, _mm256_cmp_pd(apq, _mm256_setzero_pd(), _CMP_NEQ_UQ));
	if (!od_AnyLane(on))
	{
		return;
	}
	const __m256d one = _mm256_set1_pd(1.0), sign = _mm256_set1_pd(-0.0);
	__m256d theta = _mm256_div_pd(_mm256_sub_pd(e[q][q], e[p][p]), _mm256_mul_pd(_mm256_set1_pd(2.0), apq));
	__m256d unit = od_Pick(_mm256_cmp_pd(theta, _mm256_setzero_pd(), _CMP_GE_OQ), one, _mm256_set1_pd(-1.0));
	__m256d root = _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(theta, theta), one));
	__m256d t = _mm256_div_pd(unit, _mm256_add_pd(_mm256_andnot_pd(sign, theta), root));
	__m256d c = _mm256_div_pd(one, _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(t, t), one)));
	__m256d s = _mm256_mul_pd(t, c);
	int r = 3 - p - q;
	__m256d arp = e[r][p], arq = e[r][q];
	e[r][p] = e[p][r] = od_Pick(on, _mm256_sub_pd(_mm256_mul_pd(c, arp), _mm256_mul_pd(s, arq)), arp);
	e[r][q] = e[q][r] = od_Pick(on, _mm256_add_pd(_mm256_mul_pd(s, arp), _mm256_mul_pd(c, arq)), arq);
	__m256d tapq = _mm256_mul_pd(t, apq);
	e[p][p] = od_Pick(on, _mm256_sub_pd(e[p][p], tapq), e[p][p]);
	e[q][q] = od_Pick(on, _mm256_add_pd(e[q][q], tapq), e[q][q]);
	e[p][q] = e[q][p] = od_Pick(on, _mm256_setzero_pd(), apq);
	for (int i = 0; i < 3; ++i)
	{
		__m256d vip = v[i][p], viq = v[i][q];
		v[i][p] = od_Pick(on, _mm256_sub_pd(_mm256_mul_pd(c, vip), _mm256_mul_pd(s, viq)), vip);
		v[i][q] = od_Pick(on, _mm256_add_pd(_mm256_mul_pd(s, vip), _mm256_mul_pd(c, viq)), viq);
	}
}

// od_Jacobi3, lane by lane: eigenvalues on e's diagonal, eigenvectors in v's columns.
OD_SVD4_FN void od_Jacobi4(__m256d e[3][3], __m256d v[3][3])
{
	for (int i = 0; i < 3; ++i)
	{
		for (int j = 0; j < 3; ++j)
		{
			v[i][j] = _mm256_set1_pd(i == j ? 1.0 : 0.0);
		}
	}
	__m256d active = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
	for (int sweep = 0; sweep < 32; ++sweep)
	{
		__m256d off = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(e[0][1], e[0][1]), _mm256_mul_pd(e[0][2], e[0][2])),
									_mm256_mul_pd(e[1][2], e[1][2]));
		__m256d diag = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(e[0][0], e[0][0]), _mm256_mul_pd(e[1][1], e[1][1])),
									 _mm256_mul_pd(e[2][2], e[2][2]));
		__m256d done = _mm256_or_pd(_mm256_cmp_pd(off, _mm256_mul_pd(_mm256_set1_pd(1e-36), diag), _CMP_LE_OQ),
									_mm256_cmp_pd(off, _mm256_setzero_pd(), _CMP_EQ_OQ));
		active = _mm256_andnot_pd(done, active);
		if (!od_AnyLane(active))
		{
			break;
		}
		od_Rotate4(e, v, 0, 1, active);
		od_Rotate4(e, v, 0, 2, active);
		od_Rotate4(e, v, 1, 2, active);
	}
}

// od_Svd3's sort step: where eigenvalue j exceeds eigenvalue i, the two and their columns of v trade places.
OD_SVD4_FN void od_SortPair4(__m256d value[3], __m256d v[3][3], int i, int j)
{
	__m256d swap = _mm256_cmp_pd(value[j], value[i], _CMP_GT_OQ);
	__m256d vi = value[i];
	value[i] = od_Pick(swap, value[j], vi);
	value[j] = od_Pick(swap, vi, value[j]);
	for (int r = 0; r < 3; ++r)
	{
		__m256d ci = v[r][i];
		v[r][i] = od_Pick(swap, v[r][j], ci);
		v[r][j] = od_Pick(swap, ci, v[r][j]);
	}
}

// od_Givens, lane by lane: rows p, q of b get the rotation that zeroes b[q][col]; u accumulates its transpose.
OD_SVD4_FN void od_Givens4(__m256d b[3][3], __m256d u[3][3], int p, int q, int col)
{
	__m256d x = b[p][col], y = b[q][col];
	__m256d r2 = _mm256_add_pd(_mm256_mul_pd(x, x), _mm256_mul_pd(y, y));
	__m256d r = _mm256_sqrt_pd(r2);
	__m256d fine = _mm256_and_pd(_mm256_cmp_pd(r2, _mm256_set1_pd(DBL_MIN), _CMP_GT_OQ),
								 _mm256_cmp_pd(r2, _mm256_set1_pd(DBL_MAX), _CMP_LT_OQ));
	if (_mm256_movemask_pd(fine) != 15)
	{
		double xs[4], ys[4], rs[4];
		_mm256_storeu_pd(xs, x);
		_mm256_storeu_pd(ys, y);
		_mm256_storeu_pd(rs, r);
		int lanes = _mm256_movemask_pd(fine);
		for (int k = 0; k < 4; ++k)
		{
			rs[k] = lanes & (1 << k) ? rs[k] : hypot(xs[k], ys[k]);
		}
		r = _mm256_loadu_pd(rs);
	}
	__m256d on = _mm256_cmp_pd(r, _mm256_setzero_pd(), _CMP_NEQ_UQ);
	__m256d inv = _mm256_div_pd(_mm256_set1_pd(1.0), r);
	__m256d c = _mm256_mul_pd(x, inv), s = _mm256_mul_pd(y, inv);
	__m256d ns = _mm256_xor_pd(s, _mm256_set1_pd(-0.0));
	for (int k = 0; k < 3; ++k)
	{
		__m256d bp = b[p][k], bq = b[q][k];
		b[p][k] = od_Pick(on, _mm256_add_pd(_mm256_mul_pd(c, bp), _mm256_mul_pd(s, bq)), bp);
		b[q][k] = od_Pick(on, _mm256_add_pd(_mm256_mul_pd(ns, bp), _mm256_mul_pd(c, bq)), bq);
		__m256d up = u[k][p], uq = u[k][q];
		u[k][p] = od_Pick(on, _mm256_add_pd(_mm256_mul_pd(c, up), _mm256_mul_pd(s, uq)), up);
		u[k][q] = od_Pick(on, _mm256_add_pd(_mm256_mul_pd(ns, up), _mm256_mul_pd(c, uq)), uq);
	}
}

// x[0] y[0] + x[1] y[1] + x[2] y[2], summed left to right as od_M3Mul and od_M3MulTN do.
OD_SVD4_FN __m256d od_Dot4(__m256d x0, __m256d y0, __m256d x1, __m256d y1, __m256d x2, __m256d y2)
{
	return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(x0, y0), _mm256_mul_pd(x1, y1)), _mm256_mul_pd(x2, y2));
}

// od_Svd3 of a[0..3], one matrix a lane.
OD_SVD4_KERNEL void od_Svd3x4(const od_Mat3* a, od_Mat3* u, od_Vec3* s, od_Mat3* v)
{
	__m256d m[3][3], e[3][3], vv[3][3];
	for (int k = 0; k < 9; ++k)
	{
		m[k / 3][k % 3] = _mm256_set_pd(a[3].m[k], a[2].m[k], a[1].m[k], a[0].m[k]);
	}
	for (int i = 0; i < 3; ++i) // AᵀA as od_M3MulTN; e[j][i] = e[i][j] exactly (the products commute)
	{
		for (int j = i; j < 3; ++j)
		{
			e[i][j] = e[j][i] = od_Dot4(m[0][i], m[0][j], m[1][i], m[1][j], m[2][i], m[2][j]);
		}
	}
	od_Jacobi4(e, vv);
	__m256d value[3] = { e[0][0], e[1][1], e[2][2] };
	od_SortPair4(value, vv, 0, 1);
	od_SortPair4(value, vv, 0, 2);
	od_SortPair4(value, vv, 1, 2);
	// det(V) as od_M3Det; where negative, V's last column changes sign
	__m256d det = _mm256_add_pd(
		_mm256_sub_pd(
			_mm256_mul_pd(vv[0][0], _mm256_sub_pd(_mm256_mul_pd(vv[1][1], vv[2][2]), _mm256_mul_pd(vv[1][2], vv[2][1]))),
			_mm256_mul_pd(vv[0][1], _mm256_sub_pd(_mm256_mul_pd(vv[1][0], vv[2][2]), _mm256_mul_pd(vv[1][2], vv[2][0])))),
		_mm256_mul_pd(vv[0][2], _mm256_sub_pd(_mm256_mul_pd(vv[1][0], vv[2][1]), _mm256_mul_pd(vv[1][1], vv[2][0]))));
	__m256d flip = _mm256_and_pd(_mm256_cmp_pd(det, _mm256_setzero_pd(), _CMP_LT_OQ), _mm256_set1_pd(-0.0));
	for (int r = 0; r < 3; ++r)
	{
		vv[r][2] = _mm256_xor_pd(vv[r][2], flip);
	}
	__m256d b[3][3], uu[3][3];
	for (int r = 0; r < 3; ++r) // B = A V as od_M3Mul
	{
		for (int k = 0; k < 3; ++k)
		{
			b[r][k] = od_Dot4(m[r][0], vv[0][k], m[r][1], vv[1][k], m[r][2], vv[2][k]);
			uu[r][k] = _mm256_set1_pd(r == k ? 1.0 : 0.0);
		}
	}
	od_Givens4(b, uu, 0, 1, 0);
	od_Givens4(b, uu, 0, 2, 0);
	od_Givens4(b, uu, 1, 2, 1);
	double lanes[3][3][3][4]; // U, V, then the diagonal of B in [2][k][k]
	for (int k = 0; k < 9; ++k)
	{
		_mm256_storeu_pd(lanes[0][k / 3][k % 3], uu[k / 3][k % 3]);
		_mm256_storeu_pd(lanes[1][k / 3][k % 3], vv[k / 3][k % 3]);
	}
	for (int k = 0; k < 3; ++k)
	{
		_mm256_storeu_pd(lanes[2][k][k], b[k][k]);
	}
	for (int l = 0; l < 4; ++l)
	{
		for (int k = 0; k < 9; ++k)
		{
			u[l].m[k] = lanes[0][k / 3][k % 3][l];
			v[l].m[k] = lanes[1][k / 3][k % 3][l];
		}
		s[l] = od_V3(lanes[2][0][0][l], lanes[2][1][1][l], lanes[2][2][2][l]);
	}
}
#endif

void od_Svd3Many(int count, const od_Mat3* a, od_Mat3* u, od_Vec3* s, od_Mat3* v)
{
	int done = 0;
#ifdef OD_SVD4
	if (od_Platform_HasAvx2Fma())
	{
		for (; done + 4 <= count; done += 4)
		{
			od_Svd3x4(a + done, u + done, s + done, v + done);
		}
	}
#endif
	for (; done < count; ++done)
	{
		od_Svd3(a + done, u + done, s + done, v + done);
	}
}

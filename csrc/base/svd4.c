// od_Svd3 for many matrices, eight at a time in AVX2 registers where the processor has them.
//
// Design: each lane of a 256-bit register holds one matrix, and every lane runs od_Svd3's own arithmetic
// (polar.c): the same IEEE operations (+, −, ×, ÷, √ are correctly rounded, in a lane as in a scalar register) in
// the same order, with no fused multiply-add (the kernel is compiled for "avx2" alone, so the compiler cannot
// contract a product and a sum), so each lane's U, Σ, V are od_Svd3's, bit for bit. Where od_Svd3 branches, the
// lanes take masks and blends instead:
// - Jacobi: a lane stops sweeping when od_Svd3 would have (off-diagonal mass ≤ 1e-36 of the diagonal's, or
//   zero), and skips a rotation whose pivot is zero, by keeping its old values; the sweeps go on while any lane
//   is active (od_Svd3's limit of 32): for F near a rotation 2 to 4 sweeps (3 for 74 % of 100,000 such F);
// - the eigenvalue sort is its three compare-and-swaps, each a blend of the values and columns of V; the sign of
//   det(V) flips V's last column by a masked sign bit;
// - a Givens rotation with r = 0 keeps its lane; where r² under- or overflows (a zero column of A V: rank
//   deficient A; or |A| beyond about 1e±150), that lane's r is od_Svd3's hypot, computed for that lane alone.
// Each value takes OD_SVD4_REGS = 2 registers (8 matrices a call): a rotation's divisions and square roots form
// one chain of latency, and two independent chains overlap (86-95 ns an SVD against 118-128 with one register and
// 312-330 for od_Svd3, matrices near a rotation, one core). Identical results mean the MPM trajectories do not
// depend on which path ran (tests/test_mpm_simd.py; the kernel: tests/c/test_svd4.c). The path is compiled on
// x86-64 with GCC or Clang only and runs where od_Platform_HasAvx2Fma (platform.c: processor, operating system,
// OPDEFORM_NO_AVX2); elsewhere the matrices go through od_Svd3 one by one, as do the last one or two of a count.
#include "platform.h"
#include "polar.h"

#include <float.h>
#include <string.h>

#ifdef OD_X86_AVX2
#define OD_SVD4 1
#include <immintrin.h>
#endif

#ifdef OD_SVD4
#define OD_SVD4_FN __attribute__((target("avx2"), always_inline)) static inline
#define OD_SVD4_KERNEL __attribute__((target("avx2"))) static
// Registers per value: each holds 4 matrices, and their chains of divisions and square roots (latency bound in
// one register) overlap: OD_SVD4_WIDTH matrices a call.
#define OD_SVD4_REGS 2
#define OD_SVD4_WIDTH (4 * OD_SVD4_REGS)
// A last group of this many matrices or more goes through the kernel too, padded (a kernel call of OD_SVD4_WIDTH
// costs about 2.3 od_Svd3s).
#define OD_SVD4_PART 3

typedef struct od_Lanes
{
	__m256d r[OD_SVD4_REGS];
} od_Lanes;

#define OD_LANES_BINARY(name, expr)                                                                                  \
	OD_SVD4_FN od_Lanes name(od_Lanes a, od_Lanes b)                                                                 \
	{                                                                                                                \
		od_Lanes out;                                                                                                \
		for (int k = 0; k < OD_SVD4_REGS; ++k)                                                                       \
		{                                                                                                            \
			out.r[k] = expr;                                                                                         \
		}                                                                                                            \
		return out;                                                                                                  \
	}
OD_LANES_BINARY(od_LAdd, _mm256_add_pd(a.r[k], b.r[k]))
OD_LANES_BINARY(od_LSub, _mm256_sub_pd(a.r[k], b.r[k]))
OD_LANES_BINARY(od_LMul, _mm256_mul_pd(a.r[k], b.r[k]))
OD_LANES_BINARY(od_LDiv, _mm256_div_pd(a.r[k], b.r[k]))
OD_LANES_BINARY(od_LAnd, _mm256_and_pd(a.r[k], b.r[k]))
OD_LANES_BINARY(od_LAndNot, _mm256_andnot_pd(a.r[k], b.r[k])) // (not a) and b
OD_LANES_BINARY(od_LOr, _mm256_or_pd(a.r[k], b.r[k]))
OD_LANES_BINARY(od_LXor, _mm256_xor_pd(a.r[k], b.r[k]))
// the comparisons, a lane all ones where true; unordered (NaN) is false except for "not equal"
OD_LANES_BINARY(od_LNotEqual, _mm256_cmp_pd(a.r[k], b.r[k], _CMP_NEQ_UQ))
OD_LANES_BINARY(od_LEqual, _mm256_cmp_pd(a.r[k], b.r[k], _CMP_EQ_OQ))
OD_LANES_BINARY(od_LGreater, _mm256_cmp_pd(a.r[k], b.r[k], _CMP_GT_OQ))
OD_LANES_BINARY(od_LGreaterEqual, _mm256_cmp_pd(a.r[k], b.r[k], _CMP_GE_OQ))
OD_LANES_BINARY(od_LLess, _mm256_cmp_pd(a.r[k], b.r[k], _CMP_LT_OQ))
OD_LANES_BINARY(od_LLessEqual, _mm256_cmp_pd(a.r[k], b.r[k], _CMP_LE_OQ))

OD_SVD4_FN od_Lanes od_LSet(double x)
{
	od_Lanes out;
	for (int k = 0; k < OD_SVD4_REGS; ++k)
	{
		out.r[k] = _mm256_set1_pd(x);
	}
	return out;
}

OD_SVD4_FN od_Lanes od_LSqrt(od_Lanes a)
{
	for (int k = 0; k < OD_SVD4_REGS; ++k)
	{
		a.r[k] = _mm256_sqrt_pd(a.r[k]);
	}
	return a;
}

// mask ? yes : no, lane by lane (a mask lane is all ones or all zeros)
OD_SVD4_FN od_Lanes od_LPick(od_Lanes mask, od_Lanes yes, od_Lanes no)
{
	for (int k = 0; k < OD_SVD4_REGS; ++k)
	{
		no.r[k] = _mm256_blendv_pd(no.r[k], yes.r[k], mask.r[k]);
	}
	return no;
}

// The lanes where mask is true, one bit each.
OD_SVD4_FN int od_LaneBits(od_Lanes mask)
{
	int bits = 0;
	for (int k = 0; k < OD_SVD4_REGS; ++k)
	{
		bits |= _mm256_movemask_pd(mask.r[k]) << 4 * k;
	}
	return bits;
}

// One Jacobi rotation in the (p, q) plane of the symmetric e (both triangles kept), for the lanes of `active`
// whose pivot e[p][q] is not zero: od_Jacobi3's loop body.
OD_SVD4_FN void od_Rotate4(od_Lanes e[3][3], od_Lanes v[3][3], int p, int q, od_Lanes active)
{
	od_Lanes apq = e[p][q], zero = od_LSet(0.0), one = od_LSet(1.0);
	od_Lanes on = od_LAnd(active, od_LNotEqual(apq, zero));
	if (!od_LaneBits(on))
	{
		return;
	}
	od_Lanes theta = od_LDiv(od_LSub(e[q][q], e[p][p]), od_LMul(od_LSet(2.0), apq));
	od_Lanes unit = od_LPick(od_LGreaterEqual(theta, zero), one, od_LSet(-1.0));
	od_Lanes root = od_LSqrt(od_LAdd(od_LMul(theta, theta), one));
	od_Lanes t = od_LDiv(unit, od_LAdd(od_LAndNot(od_LSet(-0.0), theta), root)); // |θ|: the sign bit cleared
	od_Lanes c = od_LDiv(one, od_LSqrt(od_LAdd(od_LMul(t, t), one)));
	od_Lanes s = od_LMul(t, c);
	int r = 3 - p - q;
	od_Lanes arp = e[r][p], arq = e[r][q], tapq = od_LMul(t, apq);
	e[r][p] = e[p][r] = od_LPick(on, od_LSub(od_LMul(c, arp), od_LMul(s, arq)), arp);
	e[r][q] = e[q][r] = od_LPick(on, od_LAdd(od_LMul(s, arp), od_LMul(c, arq)), arq);
	e[p][p] = od_LPick(on, od_LSub(e[p][p], tapq), e[p][p]);
	e[q][q] = od_LPick(on, od_LAdd(e[q][q], tapq), e[q][q]);
	e[p][q] = e[q][p] = od_LPick(on, zero, apq);
	for (int i = 0; i < 3; ++i)
	{
		od_Lanes vip = v[i][p], viq = v[i][q];
		v[i][p] = od_LPick(on, od_LSub(od_LMul(c, vip), od_LMul(s, viq)), vip);
		v[i][q] = od_LPick(on, od_LAdd(od_LMul(s, vip), od_LMul(c, viq)), viq);
	}
}

// x0 y0 + x1 y1 + x2 y2, summed left to right as od_M3Mul and od_M3MulTN do.
OD_SVD4_FN od_Lanes od_Dot4(od_Lanes x0, od_Lanes y0, od_Lanes x1, od_Lanes y1, od_Lanes x2, od_Lanes y2)
{
	return od_LAdd(od_LAdd(od_LMul(x0, y0), od_LMul(x1, y1)), od_LMul(x2, y2));
}

// od_Jacobi3, lane by lane: eigenvalues on e's diagonal, eigenvectors in v's columns.
OD_SVD4_FN void od_Jacobi4(od_Lanes e[3][3], od_Lanes v[3][3])
{
	for (int i = 0; i < 3; ++i)
	{
		for (int j = 0; j < 3; ++j)
		{
			v[i][j] = od_LSet(i == j ? 1.0 : 0.0);
		}
	}
	od_Lanes active = od_LEqual(od_LSet(0.0), od_LSet(0.0)), zero = od_LSet(0.0);
	for (int sweep = 0; sweep < 32; ++sweep)
	{
		od_Lanes off = od_Dot4(e[0][1], e[0][1], e[0][2], e[0][2], e[1][2], e[1][2]);
		od_Lanes diag = od_Dot4(e[0][0], e[0][0], e[1][1], e[1][1], e[2][2], e[2][2]);
		od_Lanes done = od_LOr(od_LLessEqual(off, od_LMul(od_LSet(1e-36), diag)), od_LEqual(off, zero));
		active = od_LAndNot(done, active);
		if (!od_LaneBits(active))
		{
			break;
		}
		od_Rotate4(e, v, 0, 1, active);
		od_Rotate4(e, v, 0, 2, active);
		od_Rotate4(e, v, 1, 2, active);
	}
}

// od_Svd3's sort step: where eigenvalue j exceeds eigenvalue i, the two and their columns of v trade places.
OD_SVD4_FN void od_SortPair4(od_Lanes value[3], od_Lanes v[3][3], int i, int j)
{
	od_Lanes swap = od_LGreater(value[j], value[i]), vi = value[i];
	value[i] = od_LPick(swap, value[j], vi);
	value[j] = od_LPick(swap, vi, value[j]);
	for (int r = 0; r < 3; ++r)
	{
		od_Lanes ci = v[r][i];
		v[r][i] = od_LPick(swap, v[r][j], ci);
		v[r][j] = od_LPick(swap, ci, v[r][j]);
	}
}

// od_Givens' r: sqrt(x² + y²), hypot for the lanes where the squares under- or overflow (a rare branch).
OD_SVD4_FN od_Lanes od_Norm4(od_Lanes x, od_Lanes y)
{
	od_Lanes r2 = od_LAdd(od_LMul(x, x), od_LMul(y, y)), r = od_LSqrt(r2);
	int fine = od_LaneBits(od_LAnd(od_LGreater(r2, od_LSet(DBL_MIN)), od_LLess(r2, od_LSet(DBL_MAX))));
	if (fine != (1 << OD_SVD4_WIDTH) - 1)
	{
		double xs[OD_SVD4_WIDTH], ys[OD_SVD4_WIDTH], rs[OD_SVD4_WIDTH];
		for (int k = 0; k < OD_SVD4_REGS; ++k)
		{
			_mm256_storeu_pd(xs + 4 * k, x.r[k]);
			_mm256_storeu_pd(ys + 4 * k, y.r[k]);
			_mm256_storeu_pd(rs + 4 * k, r.r[k]);
		}
		for (int l = 0; l < OD_SVD4_WIDTH; ++l)
		{
			rs[l] = fine & (1 << l) ? rs[l] : hypot(xs[l], ys[l]);
		}
		for (int k = 0; k < OD_SVD4_REGS; ++k)
		{
			r.r[k] = _mm256_loadu_pd(rs + 4 * k);
		}
	}
	return r;
}

// od_Givens, lane by lane: rows p, q of b get the rotation that zeroes b[q][col]; u accumulates its transpose.
OD_SVD4_FN void od_Givens4(od_Lanes b[3][3], od_Lanes u[3][3], int p, int q, int col)
{
	od_Lanes x = b[p][col], y = b[q][col], r = od_Norm4(x, y);
	od_Lanes on = od_LNotEqual(r, od_LSet(0.0)), inv = od_LDiv(od_LSet(1.0), r);
	od_Lanes c = od_LMul(x, inv), s = od_LMul(y, inv), ns = od_LXor(s, od_LSet(-0.0));
	for (int k = 0; k < 3; ++k)
	{
		od_Lanes bp = b[p][k], bq = b[q][k], up = u[k][p], uq = u[k][q];
		b[p][k] = od_LPick(on, od_LAdd(od_LMul(c, bp), od_LMul(s, bq)), bp);
		b[q][k] = od_LPick(on, od_LAdd(od_LMul(ns, bp), od_LMul(c, bq)), bq);
		u[k][p] = od_LPick(on, od_LAdd(od_LMul(c, up), od_LMul(s, uq)), up);
		u[k][q] = od_LPick(on, od_LAdd(od_LMul(ns, up), od_LMul(c, uq)), uq);
	}
}

// Entry k of the matrices a[0..OD_SVD4_WIDTH), one a lane.
OD_SVD4_FN od_Lanes od_Gather(const od_Mat3* a, int k)
{
	od_Lanes out;
	for (int h = 0; h < OD_SVD4_REGS; ++h)
	{
		const od_Mat3* m = a + 4 * h;
		out.r[h] = _mm256_set_pd(m[3].m[k], m[2].m[k], m[1].m[k], m[0].m[k]);
	}
	return out;
}

// Lane l of x into *to.
OD_SVD4_FN void od_Scatter(od_Lanes x, double* to, size_t stride)
{
	double lanes[OD_SVD4_WIDTH];
	for (int k = 0; k < OD_SVD4_REGS; ++k)
	{
		_mm256_storeu_pd(lanes + 4 * k, x.r[k]);
	}
	for (int l = 0; l < OD_SVD4_WIDTH; ++l)
	{
		to[l * stride] = lanes[l];
	}
}

// od_Svd3 of a[0..OD_SVD4_WIDTH), one matrix a lane.
OD_SVD4_KERNEL void od_Svd3Lanes(const od_Mat3* a, od_Mat3* u, od_Vec3* s, od_Mat3* v)
{
	od_Lanes m[3][3], e[3][3], vv[3][3];
	for (int k = 0; k < 9; ++k)
	{
		m[k / 3][k % 3] = od_Gather(a, k);
	}
	for (int i = 0; i < 3; ++i) // AᵀA as od_M3MulTN; e[j][i] = e[i][j] exactly (the products commute)
	{
		for (int j = i; j < 3; ++j)
		{
			e[i][j] = e[j][i] = od_Dot4(m[0][i], m[0][j], m[1][i], m[1][j], m[2][i], m[2][j]);
		}
	}
	od_Jacobi4(e, vv);
	od_Lanes value[3] = { e[0][0], e[1][1], e[2][2] };
	od_SortPair4(value, vv, 0, 1);
	od_SortPair4(value, vv, 0, 2);
	od_SortPair4(value, vv, 1, 2);
	// det(V) as od_M3Det; where negative, V's last column changes sign
	od_Lanes det = od_LAdd(od_LSub(od_LMul(vv[0][0], od_LSub(od_LMul(vv[1][1], vv[2][2]), od_LMul(vv[1][2], vv[2][1]))),
								 od_LMul(vv[0][1], od_LSub(od_LMul(vv[1][0], vv[2][2]), od_LMul(vv[1][2], vv[2][0])))),
						  od_LMul(vv[0][2], od_LSub(od_LMul(vv[1][0], vv[2][1]), od_LMul(vv[1][1], vv[2][0]))));
	od_Lanes flip = od_LAnd(od_LLess(det, od_LSet(0.0)), od_LSet(-0.0));
	for (int r = 0; r < 3; ++r)
	{
		vv[r][2] = od_LXor(vv[r][2], flip);
	}
	od_Lanes b[3][3], uu[3][3];
	for (int r = 0; r < 3; ++r) // B = A V as od_M3Mul
	{
		for (int k = 0; k < 3; ++k)
		{
			b[r][k] = od_Dot4(m[r][0], vv[0][k], m[r][1], vv[1][k], m[r][2], vv[2][k]);
			uu[r][k] = od_LSet(r == k ? 1.0 : 0.0);
		}
	}
	od_Givens4(b, uu, 0, 1, 0);
	od_Givens4(b, uu, 0, 2, 0);
	od_Givens4(b, uu, 1, 2, 1);
	for (int k = 0; k < 9; ++k)
	{
		od_Scatter(uu[k / 3][k % 3], &u->m[k], sizeof *u / sizeof(double));
		od_Scatter(vv[k / 3][k % 3], &v->m[k], sizeof *v / sizeof(double));
	}
	od_Scatter(b[0][0], &s->x, sizeof *s / sizeof(double));
	od_Scatter(b[1][1], &s->y, sizeof *s / sizeof(double));
	od_Scatter(b[2][2], &s->z, sizeof *s / sizeof(double));
}

// The last count < OD_SVD4_WIDTH matrices through the kernel, the lanes past them given the identity (which takes no
// Jacobi sweep).
OD_SVD4_KERNEL void od_Svd3LanesPart(int count, const od_Mat3* a, od_Mat3* u, od_Vec3* s, od_Mat3* v)
{
	od_Mat3 in[OD_SVD4_WIDTH], uu[OD_SVD4_WIDTH], vv[OD_SVD4_WIDTH];
	od_Vec3 ss[OD_SVD4_WIDTH];
	for (int l = 0; l < OD_SVD4_WIDTH; ++l)
	{
		in[l] = l < count ? a[l] : od_M3Identity();
	}
	od_Svd3Lanes(in, uu, ss, vv);
	memcpy(u, uu, sizeof *u * (size_t)count);
	memcpy(s, ss, sizeof *s * (size_t)count);
	memcpy(v, vv, sizeof *v * (size_t)count);
}
#endif

void od_Svd3Many(int count, const od_Mat3* a, od_Mat3* u, od_Vec3* s, od_Mat3* v)
{
	int done = 0;
#ifdef OD_SVD4
	if (od_Platform_HasAvx2Fma())
	{
		for (; done + OD_SVD4_WIDTH <= count; done += OD_SVD4_WIDTH)
		{
			od_Svd3Lanes(a + done, u + done, s + done, v + done);
		}
		if (count - done >= OD_SVD4_PART)
		{
			od_Svd3LanesPart(count - done, a + done, u + done, s + done, v + done);
			done = count;
		}
	}
#endif
	for (; done < count; ++done)
	{
		od_Svd3(a + done, u + done, s + done, v + done);
	}
}

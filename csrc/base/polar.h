// Polar decomposition and SVD of 3x3 matrices, shared by the local step and the MPM solver.
#pragma once

#include "math3.h"

// a = u diag(s) vᵀ with u, v proper rotations and s1 >= s2 >= |s3|; s3 < 0 when det(a) < 0.
void od_Svd3(const od_Mat3* a, od_Mat3* u, od_Vec3* s, od_Mat3* v);

// od_Svd3 of a[0..count), bit-identical to calling it for each: eight at a time in AVX2 registers where
// od_Platform_HasAvx2Fma (svd4.c), one by one elsewhere.
void od_Svd3Many(int count, const od_Mat3* a, od_Mat3* u, od_Vec3* s, od_Mat3* v);

// The rotation maximizing tr(rᵀ a): u vᵀ of od_Svd3 (the smallest singular vector flipped when det(a) < 0).
od_Mat3 od_PolarRotation(const od_Mat3* a);

// Same maximizer, found by Newton steps on SO(3) from the rotation *r (a warm start), which is updated
// in place. Falls back to od_PolarRotation when the Newton iteration is not clearly converging to the
// maximum. Returns 1 when the fallback was used, 0 otherwise. Each call multiplies *r by exact-to-rounding
// rotations, so callers re-orthonormalize once in a while (once per step) against drift.
int od_PolarRotationWarm(const od_Mat3* a, od_Mat3* r);

// od_PolarRotationWarm's Newton steps until one is shorter than sqrt(stepSquared) radians (the warm variant's
// 1e-6 leaves ~1e-6 rad; 1e-20 leaves rounding), with its fallback and return value.
int od_PolarRotationNewton(const od_Mat3* a, od_Mat3* r, double stepSquared);

// Solves h x = b for symmetric h by its adjugate; returns 0 unless h is clearly positive definite
// (Sylvester's criterion with the Cholesky pivots h00, minor2 / h00, det / minor2 all above tiny).
static inline int od_SolveSpd3(const od_Mat3* h, od_Vec3 b, double tiny, od_Vec3* x)
{
	const double* m = h->m;
	double c00 = m[4] * m[8] - m[5] * m[7], c01 = m[2] * m[7] - m[1] * m[8], c02 = m[1] * m[5] - m[2] * m[4];
	double minor2 = m[0] * m[4] - m[1] * m[3];
	double det = m[0] * c00 + m[3] * c01 + m[6] * c02;
	if (!(m[0] > tiny) || !(minor2 > tiny * m[0]) || !(det > tiny * minor2))
	{
		return 0;
	}
	double c11 = m[0] * m[8] - m[2] * m[6], c12 = m[2] * m[3] - m[0] * m[5], c22 = minor2;
	double inv = 1.0 / det;
	*x = od_V3(inv * (c00 * b.x + c01 * b.y + c02 * b.z), inv * (c01 * b.x + c11 * b.y + c12 * b.z),
			   inv * (c02 * b.x + c12 * b.y + c22 * b.z));
	return 1;
}

// Re-orthonormalizes a nearly orthonormal matrix (one Newton step of the polar iteration).
void od_Orthonormalize(od_Mat3* r);

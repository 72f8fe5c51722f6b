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

// Solves h x = b for symmetric h by its adjugate; returns 0 unless h is clearly positive definite
// (Sylvester's criterion with the Cholesky pivots h00, minor2 / h00, det / minor2 all above tiny).
int od_SolveSpd3(const od_Mat3* h, od_Vec3 b, double tiny, od_Vec3* x);

// Re-orthonormalizes a nearly orthonormal matrix (one Newton step of the polar iteration).
void od_Orthonormalize(od_Mat3* r);

// Polar decomposition: proper rotations, maximality of tr(RᵀA), inverted / rank-deficient / near-identity
// inputs, and agreement of the warm-started Newton path with the SVD path.
#include "polar.h"
#include "test_macros.h"

static od_Mat3 random_matrix(unsigned long long* seed, double scale)
{
	od_Mat3 a;
	for (int k = 0; k < 9; ++k)
	{
		a.m[k] = scale * (2.0 * test_random(seed) - 1.0);
	}
	return a;
}

static od_Mat3 random_rotation(unsigned long long* seed)
{
	od_Vec3 w = od_V3(2 * test_random(seed) - 1, 2 * test_random(seed) - 1, 2 * test_random(seed) - 1);
	return od_M3ExpSkew(od_Scale(3.0, w));
}

static double orthonormality_error(const od_Mat3* r)
{
	od_Mat3 rtr = od_M3MulTN(r, r);
	double e = 0.0;
	for (int k = 0; k < 9; ++k)
	{
		e = fmax(e, fabs(rtr.m[k] - (k % 4 == 0)));
	}
	return e;
}

// tr(RᵀA) must not grow when R is perturbed by a small rotation in any of 6 directions.
static int check_maximal(const od_Mat3* a, const od_Mat3* r)
{
	double best = od_M3Inner(r, a), scale = sqrt(od_M3Inner(a, a));
	for (int d = 0; d < 6; ++d)
	{
		double w[3] = { 0, 0, 0 };
		w[d % 3] = d < 3 ? 1e-3 : -1e-3;
		od_Mat3 e = od_M3ExpSkew(od_V3(w[0], w[1], w[2]));
		od_Mat3 rp = od_M3Mul(r, &e);
		ENSURE(od_M3Inner(&rp, a) <= best + 1e-12 * scale);
	}
	return 0;
}

static int check_polar(const od_Mat3* a)
{
	od_Mat3 r = od_PolarRotation(a);
	ENSURE_SMALL(orthonormality_error(&r), 1e-12);
	ENSURE_SMALL(od_M3Det(&r) - 1.0, 1e-12);
	ENSURE(check_maximal(a, &r) == 0);
	return 0;
}

int test_polar(void)
{
	unsigned long long seed = 7;
	for (int t = 0; t < 2000; ++t)
	{
		od_Mat3 a = random_matrix(&seed, 1.0 + 1e3 * test_random(&seed));
		ENSURE(check_polar(&a) == 0);

		// SVD reconstructs A, with ordered singular values and the sign of det(A) on the last one.
		od_Mat3 u, v;
		od_Vec3 s;
		od_Svd3(&a, &u, &s, &v);
		od_Mat3 us = u;
		for (int r = 0; r < 3; ++r)
		{
			us.m[3 * r] *= s.x;
			us.m[3 * r + 1] *= s.y;
			us.m[3 * r + 2] *= s.z;
		}
		od_Mat3 back = od_M3MulNT(&us, &v);
		double err = 0.0;
		for (int k = 0; k < 9; ++k)
		{
			err = fmax(err, fabs(back.m[k] - a.m[k]));
		}
		ENSURE_SMALL(err, 1e-11 * s.x);
		ENSURE(s.x >= s.y && s.y >= fabs(s.z) * (1 - 1e-12));
		ENSURE((s.z < 0) == (od_M3Det(&a) < 0) || fabs(s.z) < 1e-12 * s.x);

		// Warm start from a random rotation lands on the same maximizer.
		od_Mat3 warm = random_rotation(&seed);
		od_PolarRotationWarm(&a, &warm);
		od_Mat3 exact = od_PolarRotation(&a);
		double diff = 0.0;
		for (int k = 0; k < 9; ++k)
		{
			diff = fmax(diff, fabs(warm.m[k] - exact.m[k]));
		}
		ENSURE_SMALL(diff, 1e-7);
	}

	// Inverted: a rotation times a reflection.
	for (int t = 0; t < 200; ++t)
	{
		od_Mat3 q = random_rotation(&seed);
		od_Mat3 f = { { 1, 0, 0, 0, 2, 0, 0, 0, -0.5 } };
		od_Mat3 a = od_M3Mul(&q, &f);
		ENSURE(check_polar(&a) == 0);
		od_Mat3 r = od_PolarRotation(&a);
		// The smallest singular direction (z, 0.5) takes the sign of det: the maximizer is R = Q.
		double diff = 0.0;
		for (int k = 0; k < 9; ++k)
		{
			diff = fmax(diff, fabs(r.m[k] - q.m[k]));
		}
		ENSURE_SMALL(diff, 1e-10);
	}

	// Rank deficient: rank 2, rank 1 and zero.
	for (int t = 0; t < 200; ++t)
	{
		od_Mat3 q = random_rotation(&seed);
		od_Mat3 d2 = { { 3, 0, 0, 0, 1, 0, 0, 0, 0 } }, d1 = { { 2, 0, 0, 0, 0, 0, 0, 0, 0 } };
		od_Mat3 a2 = od_M3Mul(&q, &d2), a1 = od_M3Mul(&q, &d1);
		ENSURE(check_polar(&a2) == 0);
		ENSURE(check_polar(&a1) == 0);
		od_Mat3 r = od_PolarRotation(&a2);
		double diff = 0.0;
		for (int k = 0; k < 9; ++k)
		{
			diff = fmax(diff, fabs(r.m[k] - q.m[k]));
		}
		ENSURE_SMALL(diff, 1e-9); // rank 2 has a unique maximizer: Q
	}
	od_Mat3 zero = od_M3Zero();
	ENSURE(check_polar(&zero) == 0);

	// Near identity: R stays within round-off of I, and the warm start needs no fallback.
	for (int t = 0; t < 200; ++t)
	{
		od_Mat3 a = od_M3Identity();
		od_Mat3 noise = random_matrix(&seed, 1e-9);
		od_M3AddScaled(&a, 1.0, &noise);
		od_Mat3 r = od_M3Identity();
		ENSURE(od_PolarRotationWarm(&a, &r) == 0);
		ENSURE_SMALL(orthonormality_error(&r), 1e-14);
		ENSURE_SMALL(r.m[0] - 1.0, 1e-8);
	}
	return 0;
}

// od_Svd3Many (svd4.c) against od_Svd3 on random, near-singular, rank-deficient, inverted, repeated-singular-value
// and scaled matrices (zero columns take od_Svd3's hypot, lane by lane): bit for bit the same U, Σ, V (where the 4-wide path runs, and trivially elsewhere),
// and the factors themselves reconstruct A with proper rotations U, V.
#include "platform.h"
#include "polar.h"
#include "test_macros.h"

#include <string.h>

#define SVD4_COUNT 4003

// Matrix k of the test set: 11 kinds in turn, each a random rotation times a diagonal times a random rotation
// (or plain random entries), scaled.
static od_Mat3 svd4_case(int k, unsigned long long* seed)
{
	od_Vec3 w1 = od_V3(2 * test_random(seed) - 1, 2 * test_random(seed) - 1, 2 * test_random(seed) - 1);
	od_Vec3 w2 = od_V3(2 * test_random(seed) - 1, 2 * test_random(seed) - 1, 2 * test_random(seed) - 1);
	od_Mat3 q1 = od_M3ExpSkew(od_Scale(3.0, w1)), q2 = od_M3ExpSkew(od_Scale(3.0, w2));
	double d[3] = { 0.5 + test_random(seed), 0.5 + test_random(seed), 0.5 + test_random(seed) }, scale = 1.0;
	switch (k % 11)
	{
	case 0: // random entries
	{
		od_Mat3 a;
		for (int e = 0; e < 9; ++e)
		{
			a.m[e] = 2 * test_random(seed) - 1;
		}
		return a;
	}
	case 1: d[2] = 1e-10 * d[2]; break;      // near singular
	case 2: d[2] = 0.0; break;               // rank 2
	case 3: d[1] = d[2] = 0.0; break;        // rank 1
	case 4: d[0] = d[1] = d[2] = 0.0; break; // zero
	case 5: d[1] = -d[1]; break;             // inverted
	case 6: d[1] = d[0]; break;              // two equal singular values
	case 7: d[1] = d[2] = d[0]; break;       // three equal: a scaled rotation
	case 8: // snow: near a rotation, σ in [0.975, 1.0045]
		for (int e = 0; e < 3; ++e)
		{
			d[e] = 0.975 + 0.0295 * test_random(seed);
		}
		break;
	case 9: scale = 1e-60; break; // small and large: od_Svd3 is exact while (AᵀA)² neither under- nor
	default: scale = 1e60; break; // overflows, |A| within about 1e±75
	}
	od_Mat3 a = q1;
	for (int r = 0; r < 3; ++r)
	{
		for (int c = 0; c < 3; ++c)
		{
			a.m[3 * r + c] *= scale * d[c];
		}
	}
	return od_M3Mul(&a, &q2);
}

static double svd4_orthogonality(const od_Mat3* q)
{
	od_Mat3 qtq = od_M3MulTN(q, q);
	double e = fabs(od_M3Det(q) - 1.0);
	for (int k = 0; k < 9; ++k)
	{
		e = fmax(e, fabs(qtq.m[k] - (k % 4 == 0)));
	}
	return e;
}

// |U Σ Vᵀ − A| relative to σ1 (to the largest entry of A where A is zero).
static double svd4_reconstruction(const od_Mat3* a, const od_Mat3* u, od_Vec3 s, const od_Mat3* v)
{
	od_Mat3 us = *u;
	double sigma[3] = { s.x, s.y, s.z }, err = 0.0;
	for (int k = 0; k < 9; ++k)
	{
		us.m[k] *= sigma[k % 3];
	}
	od_Mat3 back = od_M3MulNT(&us, v);
	for (int k = 0; k < 9; ++k)
	{
		err = fmax(err, fabs(back.m[k] - a->m[k]));
	}
	return s.x > 0.0 ? err / s.x : err;
}

int test_svd4(void)
{
	static od_Mat3 a[SVD4_COUNT], u[SVD4_COUNT], v[SVD4_COUNT];
	static od_Vec3 s[SVD4_COUNT];
	unsigned long long seed = 11;
	for (int k = 0; k < SVD4_COUNT; ++k)
	{
		a[k] = svd4_case(k, &seed);
	}
	printf("  od_Svd3Many: %s\n", od_Platform_HasAvx2Fma() ? "AVX2, eight at a time" : "od_Svd3 one by one");
	for (int first = 0, count = 1; first < SVD4_COUNT; first += count, count = count % 19 + 1) // every remainder
	{
		count = first + count > SVD4_COUNT ? SVD4_COUNT - first : count;
		od_Svd3Many(count, a + first, u + first, s + first, v + first);
	}
	for (int k = 0; k < SVD4_COUNT; ++k)
	{
		od_Mat3 u1, v1;
		od_Vec3 s1;
		od_Svd3(&a[k], &u1, &s1, &v1);
		ENSURE(memcmp(&u1, &u[k], sizeof u1) == 0 && memcmp(&v1, &v[k], sizeof v1) == 0);
		ENSURE(memcmp(&s1, &s[k], sizeof s1) == 0);
		ENSURE_SMALL(svd4_orthogonality(&u[k]), 1e-14);
		ENSURE_SMALL(svd4_orthogonality(&v[k]), 1e-14);
		ENSURE_SMALL(svd4_reconstruction(&a[k], &u[k], s[k], &v[k]), 1e-14);
		double slack = 1e-14 * s[k].x; // equal or zero σ: rounding
		ENSURE(s[k].x >= s[k].y - slack && s[k].y >= fabs(s[k].z) - slack);
		bool inverted = k % 11 == 5 || (k % 11 == 0 && od_M3Det(&a[k]) < 0);
		ENSURE((s[k].z < 0) == inverted || fabs(s[k].z) <= slack); // rank deficient: σ3 is rounding
	}
	return 0;
}

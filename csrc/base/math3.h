// Small fixed-size linear algebra: 3-vectors and row-major 3x3 matrices of doubles.
// Everything is static inline so the compiler can keep it in registers in the hot loops.
#pragma once

#include <math.h>
#include <string.h>

typedef struct od_Vec3
{
	double x, y, z;
} od_Vec3;

// m[3*r + c]
typedef struct od_Mat3
{
	double m[9];
} od_Mat3;

static inline od_Vec3 od_V3(double x, double y, double z)
{
	return (od_Vec3){ x, y, z };
}

static inline od_Vec3 od_V3Load(const double* p)
{
	return (od_Vec3){ p[0], p[1], p[2] };
}

static inline void od_V3Store(double* p, od_Vec3 v)
{
	p[0] = v.x;
	p[1] = v.y;
	p[2] = v.z;
}

static inline od_Vec3 od_Add(od_Vec3 a, od_Vec3 b)
{
	return (od_Vec3){ a.x + b.x, a.y + b.y, a.z + b.z };
}

static inline od_Vec3 od_Sub(od_Vec3 a, od_Vec3 b)
{
	return (od_Vec3){ a.x - b.x, a.y - b.y, a.z - b.z };
}

static inline od_Vec3 od_Scale(double s, od_Vec3 a)
{
	return (od_Vec3){ s * a.x, s * a.y, s * a.z };
}

// a + s*b
static inline od_Vec3 od_MulAdd(od_Vec3 a, double s, od_Vec3 b)
{
	return (od_Vec3){ a.x + s * b.x, a.y + s * b.y, a.z + s * b.z };
}

static inline double od_Dot(od_Vec3 a, od_Vec3 b)
{
	return a.x * b.x + a.y * b.y + a.z * b.z;
}

static inline od_Vec3 od_Cross(od_Vec3 a, od_Vec3 b)
{
	return (od_Vec3){ a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x };
}

static inline double od_Length(od_Vec3 a)
{
	return sqrt(od_Dot(a, a));
}

// a / |a| for any finite nonzero a: divided by its largest component first, so that the square neither
// underflows (a direction of 3.5e-292 has a zero od_Length) nor overflows (one of 1e300 an infinite one).
static inline od_Vec3 od_Unit(od_Vec3 a)
{
	double m = fmax(fabs(a.x), fmax(fabs(a.y), fabs(a.z)));
	od_Vec3 b = { a.x / m, a.y / m, a.z / m };
	return od_Scale(1.0 / od_Length(b), b);
}

static inline od_Mat3 od_M3Zero(void)
{
	return (od_Mat3){ { 0 } };
}

static inline od_Mat3 od_M3Identity(void)
{
	return (od_Mat3){ { 1, 0, 0, 0, 1, 0, 0, 0, 1 } };
}

static inline od_Mat3 od_M3Load(const double* p)
{
	od_Mat3 a;
	memcpy(a.m, p, sizeof a.m);
	return a;
}

static inline void od_M3Store(double* p, const od_Mat3* a)
{
	memcpy(p, a->m, sizeof a->m);
}

static inline od_Mat3 od_M3Mul(const od_Mat3* a, const od_Mat3* b)
{
	od_Mat3 c;
	for (int r = 0; r < 3; ++r)
	{
		for (int k = 0; k < 3; ++k)
		{
			c.m[3 * r + k] = a->m[3 * r] * b->m[k] + a->m[3 * r + 1] * b->m[3 + k] + a->m[3 * r + 2] * b->m[6 + k];
		}
	}
	return c;
}

// aᵀ b
static inline od_Mat3 od_M3MulTN(const od_Mat3* a, const od_Mat3* b)
{
	od_Mat3 c;
	for (int r = 0; r < 3; ++r)
	{
		for (int k = 0; k < 3; ++k)
		{
			c.m[3 * r + k] = a->m[r] * b->m[k] + a->m[3 + r] * b->m[3 + k] + a->m[6 + r] * b->m[6 + k];
		}
	}
	return c;
}

// a bᵀ
static inline od_Mat3 od_M3MulNT(const od_Mat3* a, const od_Mat3* b)
{
	od_Mat3 c;
	for (int r = 0; r < 3; ++r)
	{
		for (int k = 0; k < 3; ++k)
		{
			c.m[3 * r + k] =
				a->m[3 * r] * b->m[3 * k] + a->m[3 * r + 1] * b->m[3 * k + 1] + a->m[3 * r + 2] * b->m[3 * k + 2];
		}
	}
	return c;
}

static inline od_Vec3 od_M3MulV(const od_Mat3* a, od_Vec3 v)
{
	return (od_Vec3){ a->m[0] * v.x + a->m[1] * v.y + a->m[2] * v.z, a->m[3] * v.x + a->m[4] * v.y + a->m[5] * v.z,
					  a->m[6] * v.x + a->m[7] * v.y + a->m[8] * v.z };
}

// aᵀ v
static inline od_Vec3 od_M3MulTV(const od_Mat3* a, od_Vec3 v)
{
	return (od_Vec3){ a->m[0] * v.x + a->m[3] * v.y + a->m[6] * v.z, a->m[1] * v.x + a->m[4] * v.y + a->m[7] * v.z,
					  a->m[2] * v.x + a->m[5] * v.y + a->m[8] * v.z };
}

static inline od_Mat3 od_M3Transpose(const od_Mat3* a)
{
	return (od_Mat3){ { a->m[0], a->m[3], a->m[6], a->m[1], a->m[4], a->m[7], a->m[2], a->m[5], a->m[8] } };
}

// a += s * b
static inline void od_M3AddScaled(od_Mat3* a, double s, const od_Mat3* b)
{
	for (int k = 0; k < 9; ++k)
	{
		a->m[k] += s * b->m[k];
	}
}

// a += s * u vᵀ
static inline void od_M3AddOuter(od_Mat3* a, double s, od_Vec3 u, od_Vec3 v)
{
	double uu[3] = { s * u.x, s * u.y, s * u.z };
	for (int r = 0; r < 3; ++r)
	{
		a->m[3 * r] += uu[r] * v.x;
		a->m[3 * r + 1] += uu[r] * v.y;
		a->m[3 * r + 2] += uu[r] * v.z;
	}
}

static inline double od_M3Det(const od_Mat3* a)
{
	const double* m = a->m;
	return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
}

static inline double od_M3Trace(const od_Mat3* a)
{
	return a->m[0] + a->m[4] + a->m[8];
}

// Frobenius inner product tr(aᵀ b).
static inline double od_M3Inner(const od_Mat3* a, const od_Mat3* b)
{
	double s = 0.0;
	for (int k = 0; k < 9; ++k)
	{
		s += a->m[k] * b->m[k];
	}
	return s;
}

// [w]x, the cross-product matrix.
static inline od_Mat3 od_M3Skew(od_Vec3 w)
{
	return (od_Mat3){ { 0, -w.z, w.y, w.z, 0, -w.x, -w.y, w.x, 0 } };
}

// I + a [w]x + b [w]x², the form of the rotations made from a vector (od_M3ExpSkew; polar.c's Cayley step).
static inline od_Mat3 od_M3SkewSeries(od_Vec3 w, double a, double b)
{
	od_Mat3 k = od_M3Skew(w);
	od_Mat3 k2 = od_M3Mul(&k, &k);
	od_Mat3 r = od_M3Identity();
	od_M3AddScaled(&r, a, &k);
	od_M3AddScaled(&r, b, &k2);
	return r;
}

// exp([w]x) by Rodrigues' formula, accurate for small angles.
static inline od_Mat3 od_M3ExpSkew(od_Vec3 w)
{
	double t2 = od_Dot(w, w);
	double a, b;
	if (t2 < 1e-8)
	{
		a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0);
		b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0);
	}
	else
	{
		double t = sqrt(t2);
		a = sin(t) / t;
		b = (1.0 - cos(t)) / t2;
	}
	return od_M3SkewSeries(w, a, b);
}

// The axis-angle vector of a rotation (inverse of od_M3ExpSkew), robust near 0 and pi.
static inline od_Vec3 od_M3LogRotation(const od_Mat3* r)
{
	const double* m = r->m;
	od_Vec3 s = { 0.5 * (m[7] - m[5]), 0.5 * (m[2] - m[6]), 0.5 * (m[3] - m[1]) }; // sin(t) * axis
	double c = 0.5 * (m[0] + m[4] + m[8] - 1.0);                                    // cos(t)
	double sn = od_Length(s);
	if (c > -0.99)
	{
		double t = atan2(sn, c);
		double f = sn > 1e-12 ? t / sn : 1.0 + sn * sn / 6.0;
		return od_Scale(f, s);
	}
	// Near pi: the axis from the largest diagonal of (R + Rᵀ)/2 + (1 - cos) ... = (1 - c) a aᵀ + c I.
	double t = atan2(sn, c);
	int k = (m[0] >= m[4] && m[0] >= m[8]) ? 0 : (m[4] >= m[8] ? 1 : 2);
	double col[3];
	for (int i = 0; i < 3; ++i)
	{
		col[i] = 0.5 * (m[3 * i + k] + m[3 * k + i]);
	}
	col[k] = m[4 * k] - c;
	od_Vec3 a = od_V3(col[0], col[1], col[2]);
	double len = od_Length(a);
	a = od_Scale(1.0 / len, a);
	if (od_Dot(a, s) < 0.0)
	{
		a = od_Scale(-1.0, a);
	}
	return od_Scale(t, a);
}

static inline int od_IsFinite3(const double* p)
{
	return isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
}

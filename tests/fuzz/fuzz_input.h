// A reader of fuzzer bytes (in the spirit of LLVM's FuzzedDataProvider, for C): integers in a range,
// doubles that are often special (0, -0, NaN, ±inf, huge, tiny, denormal) or raw bit patterns, and
// proper rotations. Once the bytes run out every read returns zero, so every input is a valid program.
// CHECK() is the harness's assertion: a broken invariant traps, and libFuzzer reports it with the input.
#pragma once

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CHECK(C)                                                                                                       \
	do                                                                                                                 \
	{                                                                                                                  \
		if (!(C))                                                                                                      \
		{                                                                                                              \
			fprintf(stderr, "fuzz invariant failed: %s (%s:%d)\n", #C, __FILE__, __LINE__);                         \
			__builtin_trap();                                                                                          \
		}                                                                                                              \
	} while (0)

// TRACE(...) prints when the environment has FUZZ_TRACE set: replay a finding with
// `FUZZ_TRACE=1 build-fuzz/tests/fuzz/TARGET crash-file` to see the calls it makes.
static inline int fuzz_tracing(void)
{
	static int state = -1;
	if (state < 0)
	{
		state = getenv("FUZZ_TRACE") != NULL;
	}
	return state;
}

#define TRACE(...)                                                                                                     \
	do                                                                                                                 \
	{                                                                                                                  \
		if (fuzz_tracing())                                                                                            \
		{                                                                                                              \
			fprintf(stderr, __VA_ARGS__);                                                                              \
		}                                                                                                              \
	} while (0)

typedef struct FuzzInput
{
	const uint8_t* data;
	size_t size;
} FuzzInput;

static inline uint8_t fuzz_byte(FuzzInput* in)
{
	if (in->size == 0)
	{
		return 0;
	}
	uint8_t b = in->data[0];
	in->data++;
	in->size--;
	return b;
}

static inline uint32_t fuzz_u32(FuzzInput* in)
{
	uint32_t v = 0;
	for (int k = 0; k < 4; ++k)
	{
		v = (v << 8) | fuzz_byte(in);
	}
	return v;
}

// An integer in [lo, hi] (one byte when the range fits in one).
static inline int fuzz_int(FuzzInput* in, int lo, int hi)
{
	uint32_t range = (uint32_t)((int64_t)hi - lo);
	uint32_t v = range < 256 ? fuzz_byte(in) : fuzz_u32(in);
	return (int)((int64_t)lo + (range == UINT32_MAX ? v : v % (range + 1)));
}

static inline double fuzz_raw_double(FuzzInput* in)
{
	uint64_t bits = 0;
	for (int k = 0; k < 8; ++k)
	{
		bits = (bits << 8) | fuzz_byte(in);
	}
	double d;
	memcpy(&d, &bits, sizeof d);
	return d;
}

// A double: mostly a modest number `scale * (small integer) / 16`, sometimes a special or raw value.
static inline double fuzz_double(FuzzInput* in, double scale)
{
	uint8_t tag = fuzz_byte(in);
	switch (tag >> 4)
	{
		case 0:
		{
			static const double special[16] = { 0.0, -0.0, 1.0, -1.0, NAN, INFINITY, -INFINITY, 1e300, -1e300,
												1e-300, DBL_MIN, 4.9e-324, DBL_MAX, 1e-12, 1e12, 0.5 };
			return special[tag & 15];
		}
		case 1:
			return fuzz_raw_double(in);
		default:
			return scale * (double)(int8_t)fuzz_byte(in) / 16.0 + scale * (double)(tag & 15) / 256.0;
	}
}

// A double that is finite and positive more often: for radii, weights and parameters.
static inline double fuzz_positive(FuzzInput* in, double scale)
{
	uint8_t tag = fuzz_byte(in);
	if (tag < 16)
	{
		return fuzz_double(in, scale);
	}
	return scale * (1.0 + fuzz_byte(in)) / 64.0;
}

static inline void fuzz_vec3(FuzzInput* in, double scale, double out[3])
{
	for (int k = 0; k < 3; ++k)
	{
		out[k] = fuzz_double(in, scale);
	}
}

// A proper rotation (row major) from a quaternion of small integers; identity when they are all zero.
static inline void fuzz_rotation(FuzzInput* in, double r[9])
{
	double q[4];
	for (int k = 0; k < 4; ++k)
	{
		q[k] = (double)(int8_t)fuzz_byte(in);
	}
	double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
	if (n == 0.0)
	{
		q[0] = 1.0;
		n = 1.0;
	}
	double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
	double m[9] = { 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
					2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
					2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y) };
	memcpy(r, m, sizeof m);
}

// A 3x3 matrix: usually a proper rotation, sometimes arbitrary numbers (improper, scaled, NaN...).
static inline void fuzz_frame(FuzzInput* in, double r[9])
{
	if (fuzz_byte(in) < 224)
	{
		fuzz_rotation(in, r);
		return;
	}
	for (int k = 0; k < 9; ++k)
	{
		r[k] = fuzz_double(in, 1.0);
	}
}

static inline int fuzz_all_finite(const double* v, size_t count)
{
	for (size_t k = 0; k < count; ++k)
	{
		if (!isfinite(v[k]))
		{
			return 0;
		}
	}
	return 1;
}

// Tiny test macros (in the spirit of Box2D's test harness): a failed check prints where and returns 1.
#pragma once

#include <math.h>
#include <stdio.h>

#define ENSURE(C)                                                                                                      \
	do                                                                                                                 \
	{                                                                                                                  \
		if (!(C))                                                                                                      \
		{                                                                                                              \
			printf("  check failed: %s (%s:%d)\n", #C, __FILE__, __LINE__);                                          \
			return 1;                                                                                                  \
		}                                                                                                              \
	} while (0)

#define ENSURE_SMALL(A, TOL)                                                                                           \
	do                                                                                                                 \
	{                                                                                                                  \
		double ensure_value_ = (A);                                                                                    \
		if (!(fabs(ensure_value_) <= (TOL)))                                                                           \
		{                                                                                                              \
			printf("  check failed: |%s| = %.3g > %.3g (%s:%d)\n", #A, ensure_value_, (double)(TOL), __FILE__,      \
				   __LINE__);                                                                                          \
			return 1;                                                                                                  \
		}                                                                                                              \
	} while (0)

#define RUN_TEST(T)                                                                                                    \
	do                                                                                                                 \
	{                                                                                                                  \
		int test_result_ = T();                                                                                        \
		printf("%-40s %s\n", #T, test_result_ ? "FAILED" : "ok");                                                     \
		failures += test_result_ != 0;                                                                                 \
		total += 1;                                                                                                    \
	} while (0)

// Deterministic random numbers for tests.
static inline double test_random(unsigned long long* state)
{
	*state = *state * 6364136223846793005ULL + 1442695040888963407ULL;
	return (double)(*state >> 11) * (1.0 / 9007199254740992.0);
}

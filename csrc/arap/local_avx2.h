// The local step's AVX2 kernel (local_avx2.c): one particle's sum C_i with the rows of the 3x3 matrices in 256-bit
// registers, on x86-64 processors where od_Platform_HasAvx2Fma.
#pragma once

#include "sim.h"

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__) && !defined(OD_NO_VECTOR_EXTENSIONS)
#define OD_LOCAL_AVX2 1

// The edges' and the inertia's part of particle i's matrix C_i (od_LocalMatrix), row-major into c:
// Σ_j R_j M_e + (x_j - x_i) a_eᵀ over its edges e, then + (ρ/h²) R̃_i Ā_i in a dynamic step; bit-identical to the
// scalar path (the same products, summed in the same order).
void od_LocalAvx2_Sum(const od_Sim* sim, int i, double c[9]);
#endif

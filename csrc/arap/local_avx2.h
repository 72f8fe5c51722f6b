// The local step's AVX2 kernels (local_avx2.c): one particle's sum C_i with the rows of the 3x3 matrices in 256-bit
// registers, and the polar decompositions of a batch of particles in the lanes, on x86-64 processors where
// od_Platform_HasAvx2Fma.
#pragma once

#include "platform.h"
#include "sim.h"

// The most particles a batch of the sweep (local_step.c), one a lane of a register of doubles.
#define OD_LOCAL_LANES 4

#ifdef OD_X86_AVX2
#define OD_LOCAL_AVX2 1

// The edges' and the inertia's part of particle i's matrix C_i (od_LocalMatrix), row-major into c:
// Σ_j R_j M_e + (x_j - x_i) a_eᵀ over its edges e, then + (ρ/h²) R̃_i Ā_i in a dynamic step; bit-identical to the
// scalar path (the same products, summed in the same order).
void od_LocalAvx2_Sum(const od_Sim* sim, int i, double c[9]);

// The rotations of particles members[0..count), 2 to OD_LOCAL_LANES of them, none touching a constraint and none
// a neighbour of another: each C_i as od_LocalMatrix forms it, each R_i <- od_PolarRotationWarm(C_i, R_i), in the
// lanes and bit-identical to the scalar path; returns how many fell back to the SVD.
int od_LocalAvx2_Batch(od_Sim* sim, const int* members, int count);
#endif

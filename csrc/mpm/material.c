// Materials of the MPM world: snow plasticity (Stomakhin 2013), fixed-corotated stress, jelly and flakes.
//
// Design: one SVD per particle and substep (od_Svd3, F = U Σ Vᵀ with proper U, V) serves the plasticity
// projection and the stress; G2P computes it for a batch of particles (od_Svd3Many, eight at a time in AVX2
// registers where the processor has them, the same bits) and hands each particle's to od_MpmMaterial_Update. Every material is "clamp Σ, then fixed-corotated stress of the clamped F":
// - snow clamps each σ to [1 − θc, 1 + θs], moves the removed volume into Jp and hardens μ, λ by
//   exp(ξ (1 − Jp));
// - jelly clamps nothing;
// - flakes set every σ to the cube root of J (shear is fully plastic) with J ≤ 1 (no tension), so loose
//   flakes fall apart freely yet still resist compression; F keeps its rotation U Vᵀ, which is what
//   turns the flakes.
// The fixed-corotated Kirchhoff stress τ = 2μ (F − R) Fᵀ + λ J (J − 1) I equals U diag(2μ (σ − 1) σ +
// λ J (J − 1)) Uᵀ, so no matrix product with R is needed.
#include "world.h"

#include "core.h"

od_MpmMaterial od_MpmSnowMaterial(void)
{
	return (od_MpmMaterial){ .kind = OD_MPM_SNOW,
							 .density = 600.0,
							 .youngModulus = 5e3,
							 .poissonRatio = 0.3,
							 .criticalCompression = 2.5e-2,
							 .criticalStretch = 4.5e-3,
							 .hardening = 10.0 };
}

od_MpmMaterial od_MpmJellyMaterial(void)
{
	od_MpmMaterial m = od_MpmSnowMaterial();
	m.kind = OD_MPM_JELLY;
	m.density = 1000.0;
	m.youngModulus = 1e5;
	return m;
}

od_MpmMaterial od_MpmFlakeMaterial(void)
{
	od_MpmMaterial m = od_MpmSnowMaterial();
	m.kind = OD_MPM_FLAKES;
	m.density = 100.0;
	m.youngModulus = 1e3;
	return m;
}

od_Status od_MpmMaterial_Check(const od_MpmMaterial* m)
{
	if (m->kind != OD_MPM_SNOW && m->kind != OD_MPM_JELLY && m->kind != OD_MPM_FLAKES)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "material: unknown kind %d", (int)m->kind);
	}
	if (!(m->density > 0.0) || !isfinite(m->density))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "material: density must be > 0, got %g", m->density);
	}
	if (!(m->youngModulus > 0.0) || !isfinite(m->youngModulus))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "material: young_modulus must be > 0, got %g", m->youngModulus);
	}
	if (!(m->poissonRatio >= 0.0 && m->poissonRatio < 0.5))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "material: poisson_ratio must be in [0, 0.5), got %g", m->poissonRatio);
	}
	if (!(m->criticalCompression >= 0.0 && m->criticalCompression < 1.0) || !(m->criticalStretch >= 0.0) ||
		!isfinite(m->criticalStretch) || !(m->hardening >= 0.0) || !isfinite(m->hardening))
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "material: need 0 <= critical_compression < 1, critical_stretch >= 0, hardening >= 0");
	}
	return OD_OK;
}

void od_MpmMaterial_Derive(od_MpmMaterialSlot* slot)
{
	const od_MpmMaterial* m = &slot->def;
	slot->mu0 = m->youngModulus / (2.0 * (1.0 + m->poissonRatio));
	slot->lambda0 = m->youngModulus * m->poissonRatio / ((1.0 + m->poissonRatio) * (1.0 - 2.0 * m->poissonRatio));
	slot->mass = m->density * slot->volume;
}

double od_MpmMaterial_WaveSpeed(const od_MpmMaterialSlot* slot, double h)
{
	return sqrt((slot->lambda0 + 2.0 * slot->mu0) * h / slot->def.density);
}

static double od_Clamp(double x, double lo, double hi)
{
	return x < lo ? lo : (x > hi ? hi : x);
}

double od_MpmMaterial_Update(const od_MpmMaterialSlot* slot, od_MpmParticle* p, const od_Mat3* U, od_Vec3 sv,
							 const od_Mat3* V)
{
	const od_MpmMaterial* m = &slot->def;
	double s[3] = { sv.x, sv.y, sv.z }, h = 1.0;
	if (m->kind == OD_MPM_SNOW)
	{
		double before = fabs(s[0] * s[1] * s[2]);
		for (int k = 0; k < 3; ++k)
		{
			s[k] = od_Clamp(s[k], 1.0 - m->criticalCompression, 1.0 + m->criticalStretch);
		}
		p->Jp *= before / (s[0] * s[1] * s[2]);
		h = exp(m->hardening * (1.0 - p->Jp));
	}
	else if (m->kind == OD_MPM_FLAKES)
	{
		double c = cbrt(od_Clamp(s[0] * s[1] * s[2], 0.1, 1.0));
		s[0] = s[1] = s[2] = c;
	}
	if (m->kind != OD_MPM_JELLY)
	{
		// F = U diag(s) Vᵀ
		od_Mat3 us = *U;
		for (int r = 0; r < 3; ++r)
		{
			for (int k = 0; k < 3; ++k)
			{
				us.m[3 * r + k] *= s[k];
			}
		}
		od_Mat3 F = od_M3MulNT(&us, V);
		od_M3Store(p->F, &F);
	}
	double J = s[0] * s[1] * s[2], mu = slot->mu0 * h, lambda = slot->lambda0 * h, d[3];
	for (int k = 0; k < 3; ++k)
	{
		d[k] = 2.0 * mu * (s[k] - 1.0) * s[k] + lambda * J * (J - 1.0);
	}
	// τ = U diag(d) Uᵀ, symmetric: xx yy zz xy xz yz
	static const int rows[6] = { 0, 1, 2, 0, 0, 1 }, cols[6] = { 0, 1, 2, 1, 2, 2 };
	for (int e = 0; e < 6; ++e)
	{
		const double* a = &U->m[3 * rows[e]];
		const double* b = &U->m[3 * cols[e]];
		p->tau[e] = a[0] * d[0] * b[0] + a[1] * d[1] * b[1] + a[2] * d[2] * b[2];
	}
	return h;
}

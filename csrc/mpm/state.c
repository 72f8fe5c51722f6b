// The MPM world's saved state (od_MpmWorld_SaveState / od_MpmWorld_LoadState): plain bytes of this build.
//
// Layout: a header (magic, counts, substeps since the last reorder, the CFL inputs, statistics), the material
// slots, the particles (in their block order), both quaternion arrays (by particle id) and each collider's
// frames.
//
// Design: loading parses untrusted bytes (a damaged or crafted pickle, issue 28), so every count, index and
// number is checked against what a substep relies on before the world is touched, and only then is the world
// grown and written, in one go: a refused state changes nothing. What a substep relies on: the ids are a
// permutation of 0..n-1 (they index the orientation and output arrays), a particle's material is in the
// table, its position is where a substep keeps particles (one cell inside the grid: positions index the
// block table), every field is finite, the quaternions are unit, the collider rotations proper, and a
// material slot's derived constants are those of its definition.
#include "world.h"

#include "check.h"
#include "core.h"
#include "interrupt.h"

#include <stdbool.h>
#include <string.h>

#define OD_MPM_STATE_MAGIC "odmpm01"
#define OD_MPM_STATE_CHUNK ((size_t)1 << 22) // bytes saved between interrupt checks (about 1 ms)
#define OD_MPM_QUAT_TOLERANCE 1e-6 // |q|² - 1 of a saved quaternion, as od_MpmWorld_AddParticles allows

typedef struct od_MpmStateHeader
{
	char magic[8];
	int count, materialCount, colliderCount, sinceReorder;
	double maxSpeed, maxHardening;
	od_MpmStats stats;
} od_MpmStateHeader;

typedef struct od_MpmFrames
{
	od_Mat3 R0, R1, R;
	od_Vec3 t0, t1, omega, velocity, t;
} od_MpmFrames;

static size_t od_StateBytes(int count, int materials, int colliders)
{
	return sizeof(od_MpmStateHeader) + sizeof(od_MpmMaterialSlot) * (size_t)materials +
		   (sizeof(od_MpmParticle) + 8 * sizeof(double)) * (size_t)count + sizeof(od_MpmFrames) * (size_t)colliders;
}

size_t od_MpmWorld_StateSize(const od_MpmWorld* w)
{
	return od_StateBytes(w->state.count, w->model.materialCount, w->colliderCount);
}

// Copies n bytes between a field and the blob at *at, in the direction `save` says; advances *at. Saving
// polls for interrupts every OD_MPM_STATE_CHUNK bytes (the world is only read); a load has checked everything
// and writes in one go.
static od_Status od_Transfer(char** at, void* field, size_t n, bool save)
{
	for (size_t done = 0; done < n; done += OD_MPM_STATE_CHUNK)
	{
		od_Status status = save ? od_CheckInterrupt() : OD_OK;
		if (status != OD_OK)
		{
			return status;
		}
		size_t part = n - done < OD_MPM_STATE_CHUNK ? n - done : OD_MPM_STATE_CHUNK;
		memcpy(save ? *at + done : (char*)field + done, save ? (char*)field + done : *at + done, part);
	}
	*at += n;
	return OD_OK;
}

static od_Status od_TransferBody(od_MpmWorld* w, char* at, bool save)
{
	size_t n = (size_t)w->state.count;
	od_Status status =
		od_Transfer(&at, w->model.materials, sizeof(od_MpmMaterialSlot) * (size_t)w->model.materialCount, save);
	status = status == OD_OK ? od_Transfer(&at, w->state.particles, sizeof(od_MpmParticle) * n, save) : status;
	status = status == OD_OK ? od_Transfer(&at, w->state.quat, 4 * sizeof(double) * n, save) : status;
	status = status == OD_OK ? od_Transfer(&at, w->state.polarQuat, 4 * sizeof(double) * n, save) : status;
	for (int k = 0; k < w->colliderCount && status == OD_OK; ++k)
	{
		od_Collider* c = &w->colliders[k].body;
		od_MpmFrames f = { c->R0, c->R1, c->R, c->t0, c->t1, c->omega, c->velocity, c->t };
		status = od_Transfer(&at, &f, sizeof f, save);
		c->R0 = f.R0, c->R1 = f.R1, c->R = f.R;
		c->t0 = f.t0, c->t1 = f.t1, c->omega = f.omega, c->velocity = f.velocity, c->t = f.t;
	}
	return status;
}

od_Status od_MpmWorld_SaveState(const od_MpmWorld* w, void* out)
{
	od_MpmStateHeader h;
	memset(&h, 0, sizeof h); // no stray padding bytes in the file
	memcpy(h.magic, OD_MPM_STATE_MAGIC, sizeof h.magic);
	h.count = w->state.count;
	h.materialCount = w->model.materialCount;
	h.colliderCount = w->colliderCount;
	h.sinceReorder = w->state.sinceReorder;
	h.maxSpeed = w->state.maxSpeed;
	h.maxHardening = w->state.maxHardening;
	h.stats = w->state.stats;
	memcpy(out, &h, sizeof h);
	return od_TransferBody((od_MpmWorld*)w, (char*)out + sizeof h, true);
}

static bool od_NonNegative(double x)
{
	return isfinite(x) && x >= 0.0;
}

static od_Status od_CheckHeader(const od_MpmWorld* w, const od_MpmStateHeader* h, size_t size)
{
	if (h->colliderCount != w->colliderCount)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "state: saved with %d colliders, the world has %d", h->colliderCount,
					   w->colliderCount);
	}
	if (h->count < 0 || h->count > OD_MPM_MAX_PARTICLES || h->materialCount < 0 ||
		h->materialCount > OD_MPM_MAX_MATERIALS || size != od_StateBytes(h->count, h->materialCount, h->colliderCount))
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "state: %zu bytes do not hold what the header says (%d particles in [0, %d], %d materials in "
					   "[0, %d])",
					   size, h->count, OD_MPM_MAX_PARTICLES, h->materialCount, OD_MPM_MAX_MATERIALS);
	}
	if (h->sinceReorder < 0 || h->sinceReorder > OD_MPM_REORDER_EVERY)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "state: substeps since the last reorder = %d must be in [0, %d]",
					   h->sinceReorder, OD_MPM_REORDER_EVERY);
	}
	const od_MpmStats* s = &h->stats;
	if (!od_NonNegative(h->maxSpeed) || !(isfinite(h->maxHardening) && h->maxHardening > 0.0) ||
		s->substeps < 0 || s->lastSubsteps < 0 || !isfinite(s->time) || !od_NonNegative(s->lastDt) ||
		s->activeBlocks < 0 || !od_NonNegative(s->maxSpeed))
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "state: the clock or the CFL inputs are out of range (max speed %g, hardening %g, time %g, "
					   "last dt %g, %lld substeps)",
					   h->maxSpeed, h->maxHardening, s->time, s->lastDt, s->substeps);
	}
	return OD_OK;
}

static od_Status od_CheckMaterials(const char* at, int count)
{
	for (int k = 0; k < count; ++k)
	{
		od_MpmMaterialSlot slot, derived;
		memcpy(&slot, at + sizeof slot * (size_t)k, sizeof slot);
		od_Status status = od_MpmMaterial_Check(&slot.def);
		if (status != OD_OK)
		{
			return status;
		}
		derived = slot;
		od_MpmMaterial_Derive(&derived);
		if (!(slot.volume > 0.0) || !isfinite(slot.volume) || derived.mass != slot.mass || derived.mu0 != slot.mu0 ||
			derived.lambda0 != slot.lambda0)
		{
			return od_Fail(OD_ERROR_ARGUMENT,
						   "state: material slot %d: particle volume %g, mass %g or elastic constants that its "
						   "definition does not give",
						   k, slot.volume, slot.mass);
		}
	}
	return OD_OK;
}

static bool od_FiniteRange(const double* x, int n)
{
	for (int k = 0; k < n; ++k)
	{
		if (!isfinite(x[k]))
		{
			return false;
		}
	}
	return true;
}

static od_Status od_CheckParticle(const od_MpmWorld* w, const od_MpmParticle* p, int i, int materials)
{
	double dx = 1.0 / w->model.invDx; // where a substep keeps particles (transfer.c): one cell inside the grid
	for (int a = 0; a < 3; ++a)
	{
		double lo = w->model.def.lower[a] + dx, hi = w->model.def.lower[a] + (w->grid.cells[a] - 1) * dx;
		if (!(p->x[a] >= lo && p->x[a] <= hi))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "state: particle %d at (%g, %g, %g) is outside the domain's inner cells",
						   i, p->x[0], p->x[1], p->x[2]);
		}
	}
	if (p->material < 0 || p->material >= materials)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "state: particle %d has material %d; the table holds %d", i, p->material,
					   materials);
	}
	if (!od_FiniteRange(p->v, 3) || !od_FiniteRange(p->C, 9) || !od_FiniteRange(p->F, 9) || !od_FiniteRange(p->tau, 6))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "state: particle %d: a velocity, affine, deformation or stress value is "
										  "not finite", i);
	}
	if (!(isfinite(p->Jp) && p->Jp > 0.0))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "state: particle %d: plastic J = %g must be finite and > 0", i, p->Jp);
	}
	return OD_OK;
}

// Every particle, and its ids as a permutation of 0..count-1 (`seen`: count bytes, zero).
static od_Status od_CheckParticles(const od_MpmWorld* w, const char* at, int count, int materials, char* seen)
{
	for (int i = 0; i < count; ++i)
	{
		od_MpmParticle p;
		memcpy(&p, at + sizeof p * (size_t)i, sizeof p);
		if (p.id < 0 || p.id >= count)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "state: particle %d has id %d, outside [0, %d)", i, p.id, count);
		}
		if (seen[p.id]++)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "state: particle id %d appears twice", p.id);
		}
		od_Status status = od_CheckParticle(w, &p, i, materials);
		if (status != OD_OK)
		{
			return status;
		}
	}
	return OD_OK;
}

static od_Status od_CheckQuaternions(const char* at, int count, const char* name)
{
	for (int i = 0; i < count; ++i)
	{
		double q[4];
		memcpy(q, at + sizeof q * (size_t)i, sizeof q);
		double n = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
		if (!(fabs(n - 1.0) < OD_MPM_QUAT_TOLERANCE))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "state: %s %d is not a unit quaternion (|q|² = %g)", name, i, n);
		}
	}
	return OD_OK;
}

static od_Status od_CheckFrames(const char* at, int colliders)
{
	for (int k = 0; k < colliders; ++k)
	{
		od_MpmFrames f;
		memcpy(&f, at + sizeof f * (size_t)k, sizeof f);
		od_Mat3 r[3] = { f.R0, f.R1, f.R };
		od_Vec3 v[5] = { f.t0, f.t1, f.omega, f.velocity, f.t };
		bool finite = true;
		for (int j = 0; j < 5; ++j)
		{
			finite = finite && isfinite(v[j].x) && isfinite(v[j].y) && isfinite(v[j].z);
		}
		for (int j = 0; j < 3; ++j)
		{
			if (od_CheckRotations("state: collider frame rotation", r[j].m, 1) != OD_OK)
			{
				return od_Fail(OD_ERROR_ARGUMENT, "state: collider %d: a frame's rotation is not proper", k);
			}
		}
		if (!finite)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "state: collider %d: a translation or velocity is not finite", k);
		}
	}
	return OD_OK;
}

static od_Status od_CheckBody(const od_MpmWorld* w, const od_MpmStateHeader* h, const char* at)
{
	size_t n = (size_t)h->count;
	od_Status status = od_CheckMaterials(at, h->materialCount);
	at += sizeof(od_MpmMaterialSlot) * (size_t)h->materialCount;
	if (status == OD_OK)
	{
		char* seen = od_AllocZero(n + 1, 1);
		status = seen ? od_CheckParticles(w, at, h->count, h->materialCount, seen)
					  : od_Fail(OD_ERROR_MEMORY, "state: out of memory for %d particles", h->count);
		od_Free(seen);
	}
	at += sizeof(od_MpmParticle) * n;
	status = status == OD_OK ? od_CheckQuaternions(at, h->count, "orientation") : status;
	at += 4 * sizeof(double) * n;
	status = status == OD_OK ? od_CheckQuaternions(at, h->count, "last polar rotation") : status;
	at += 4 * sizeof(double) * n;
	return status == OD_OK ? od_CheckFrames(at, h->colliderCount) : status;
}

od_Status od_MpmWorld_LoadState(od_MpmWorld* w, const void* in, size_t size)
{
	od_MpmStateHeader h;
	if (size < sizeof h || (memcpy(&h, in, sizeof h), memcmp(h.magic, OD_MPM_STATE_MAGIC, sizeof h.magic) != 0))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "state: not an MPM state saved by this build");
	}
	od_Status status = od_CheckHeader(w, &h, size);
	status = status == OD_OK ? od_CheckBody(w, &h, (const char*)in + sizeof h) : status;
	status = status == OD_OK ? od_MpmWorld_Reserve(w, h.count) : status;
	if (status != OD_OK)
	{
		return status;
	}
	w->state.count = h.count;
	w->model.materialCount = h.materialCount;
	od_TransferBody(w, (char*)in + sizeof h, false);
	w->state.sinceReorder = h.sinceReorder;
	w->state.maxSpeed = h.maxSpeed;
	w->state.maxHardening = h.maxHardening;
	w->state.stats = h.stats;
	return OD_OK;
}

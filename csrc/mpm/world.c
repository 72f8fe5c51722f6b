// The MPM world: creation, particles, wind and colliders, and the substep driver with its CFL bound.
//
// Design: a Step of a frame's duration runs substeps of Δt = min(maxDt, cfl Δx / (v + c)), where v is
// the fastest particle or collider point and c the elastic wave speed at the largest hardening that the
// last substep produced; the last substeps are evened out so that the frame ends exactly. A substep is
// sort (grid.c) -> P2G -> grid update -> G2P (transfer.c). Orientations are updated once per
// Step (rotation.c). All buffers are sized when particles are added; the grid's node pool grows
// during the first substeps only. Adding particles polls for interrupts every 4,096 particles checked or
// copied; a batch is counted only once whole, so a stopped add leaves the world as it was.
#include "world.h"

#include "core.h"
#include "interrupt.h"

#include <stdbool.h>
#include <string.h>

#define OD_MPM_GROW_PIECE ((size_t)1 << 22) // bytes copied between interrupt checks when the arrays grow (4 MiB)
#define OD_MPM_ADD_POLL 4095 // particles checked or copied between interrupt checks, less one (a power of two less one)

od_MpmWorldDef od_DefaultMpmWorldDef(void)
{
	return (od_MpmWorldDef){ .lower = { 0, 0, 0 },
							 .upper = { 1, 1, 1 },
							 .dx = 1.0 / 64,
							 .gravity = { 0, 0, -9.81 },
							 .cfl = 0.4,
							 .maxDt = 1e-3,
							 .spin = 1.0,
							 .walls = OD_MPM_SLIP,
							 .threads = 0 };
}

od_MpmParticlesDef od_DefaultMpmParticlesDef(void)
{
	return (od_MpmParticlesDef){ .particleVolume = 0.0, .material = od_MpmSnowMaterial() };
}

static od_Status od_CheckDef(const od_MpmWorldDef* d)
{
	for (int a = 0; a < 3; ++a)
	{
		if (!isfinite(d->lower[a]) || !isfinite(d->upper[a]) || !(d->upper[a] > d->lower[a]))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "world: the domain needs finite lower < upper on every axis");
		}
	}
	if (!(d->dx > 0.0) || !isfinite(d->dx))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "world: dx must be > 0, got %g", d->dx);
	}
	for (int a = 0; a < 3; ++a)
	{
		if ((d->upper[a] - d->lower[a]) / d->dx < 8.0)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "world: the domain must span at least 8 cells on every axis");
		}
	}
	if (!od_IsFinite3(d->gravity) || !(d->cfl > 0.0 && d->cfl <= 1.0) || !(d->maxDt > 0.0) || !isfinite(d->maxDt) ||
		!isfinite(d->spin) || !(d->wallFriction >= 0.0) || d->walls < OD_MPM_STICKY ||
		d->walls > OD_MPM_SEPARATE)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "world: need finite gravity and spin, 0 < cfl <= 1, max_dt > 0, wall "
										  "friction >= 0 and a known wall contact");
	}
	return od_Pool_CheckThreads(d->threads);
}

od_Status od_MpmWorld_Create(const od_MpmWorldDef* def, od_MpmWorld** out)
{
	*out = NULL;
	od_Status status = od_CheckDef(def);
	if (status != OD_OK)
	{
		return status;
	}
	od_MpmWorld* w = od_AllocZero(1, sizeof *w);
	if (!w)
	{
		return od_Fail(OD_ERROR_MEMORY, "world: out of memory");
	}
	w->model.def = *def;
	w->model.invDx = 1.0 / def->dx;
	w->state.maxHardening = 1.0;
	od_MpmWindDef wind = od_DefaultMpmWindDef();
	status = od_MpmWind_Set(&w->model.wind, &wind, def->dx);
	if (status == OD_OK)
	{
		status = od_MpmGrid_Init(w);
	}
	if (status == OD_OK)
	{
		status = od_Pool_Create(def->threads, &w->pool);
	}
	if (status == OD_OK)
	{
		w->threadData = od_AllocZero((size_t)od_Pool_Threads(w->pool), sizeof *w->threadData);
		status = w->threadData ? OD_OK : od_Fail(OD_ERROR_MEMORY, "world: out of memory");
	}
	if (status != OD_OK)
	{
		od_MpmWorld_Destroy(w);
		return status;
	}
	*out = w;
	return OD_OK;
}

void od_MpmWorld_Destroy(od_MpmWorld* w)
{
	if (!w)
	{
		return;
	}
	for (int c = 0; c < w->colliderCount; ++c)
	{
		od_MpmCollider_Destroy(&w->colliders[c]);
	}
	od_Free(w->colliders);
	od_FieldSet_Destroy(&w->model.fields);
	od_Free(w->state.particles);
	od_Free(w->spare);
	od_Free(w->state.quat);
	od_Free(w->state.polarQuat);
	od_MpmGrid_Destroy(&w->grid);
	od_MpmSort_Destroy(&w->sort);
	od_Pool_Destroy(w->pool);
	od_Free(w->threadData);
	od_Free(w);
}

od_MpmWorldDef od_MpmWorld_GetDef(const od_MpmWorld* w)
{
	return w->model.def;
}

int od_MpmWorld_GetParticleCount(const od_MpmWorld* w)
{
	return w->state.count;
}

od_MpmStats od_MpmWorld_GetStats(const od_MpmWorld* w)
{
	return w->state.stats;
}

static od_Status od_CheckParticles(const od_MpmWorld* w, const od_MpmParticlesDef* d)
{
	if (d->count < 1 || !d->positions)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "particles: need at least one particle (got %d)", d->count);
	}
	if (w->model.materialCount == OD_MPM_MAX_MATERIALS)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "particles: at most %d batches per world", OD_MPM_MAX_MATERIALS);
	}
	if (!(d->particleVolume > 0.0) || !isfinite(d->particleVolume))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "particles: particle_volume must be > 0, got %g", d->particleVolume);
	}
	od_Status status = od_MpmMaterial_Check(&d->material);
	if (status != OD_OK)
	{
		return status;
	}
	double margin = 2.0 * w->model.def.dx;
	for (int i = 0; i < d->count; ++i)
	{
		status = (i & OD_MPM_ADD_POLL) == 0 ? od_CheckInterrupt() : OD_OK;
		if (status != OD_OK)
		{
			return status;
		}
		const double* x = d->positions + 3 * i;
		if (!od_IsFinite3(x))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "particles: position %d is not finite", i);
		}
		for (int a = 0; a < 3; ++a)
		{
			if (x[a] < w->model.def.lower[a] + margin || x[a] > w->model.def.upper[a] - margin)
			{
				return od_Fail(OD_ERROR_ARGUMENT,
							   "particles: position %d (%g, %g, %g) is outside the domain shrunk by two cells", i, x[0],
							   x[1], x[2]);
			}
		}
		if ((d->velocities && !od_IsFinite3(d->velocities + 3 * i)) ||
			(d->affine && !(od_IsFinite3(d->affine + 9 * i) && od_IsFinite3(d->affine + 9 * i + 3) &&
							od_IsFinite3(d->affine + 9 * i + 6))))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "particles: velocity or affine matrix %d is not finite", i);
		}
		if (d->orientations)
		{
			const double* q = d->orientations + 4 * i;
			double n = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
			if (!(fabs(n - 1.0) < 1e-6))
			{
				return od_Fail(OD_ERROR_ARGUMENT, "particles: orientation %d is not a unit quaternion", i);
			}
		}
	}
	return OD_OK;
}

// Moves *array's first `used` bytes into a new block of `bytes`, a piece at a time with an interrupt check
// between pieces (realloc copies a block it cannot extend in place in one go: on Windows, adding 2.1 million
// particles to as many stopped Ctrl-C for 1.0 s under wine); *array is unchanged on failure.
static od_Status od_Grow(void** array, size_t used, size_t bytes, int capacity)
{
	char* p = od_Alloc(bytes);
	if (!p)
	{
		return od_Fail(OD_ERROR_MEMORY, "particles: out of memory for %d particles", capacity);
	}
	for (size_t at = 0; at < used; at += OD_MPM_GROW_PIECE)
	{
		od_Status status = od_CheckInterrupt();
		if (status != OD_OK)
		{
			od_Free(p);
			return status;
		}
		memcpy(p + at, (const char*)*array + at, used - at < OD_MPM_GROW_PIECE ? used - at : OD_MPM_GROW_PIECE);
	}
	od_Free(*array);
	*array = p;
	return OD_OK;
}

od_Status od_MpmWorld_Reserve(od_MpmWorld* w, int capacity)
{
	if (capacity <= w->state.capacity)
	{
		return OD_OK;
	}
	void** arrays[4] = { (void**)&w->state.particles, (void**)&w->spare, (void**)&w->state.quat,
						 (void**)&w->state.polarQuat };
	size_t sizes[4] = { sizeof(od_MpmParticle), sizeof(od_MpmParticle), 4 * sizeof(double), 4 * sizeof(double) };
	for (int k = 0; k < 4; ++k)
	{
		size_t used = arrays[k] == (void**)&w->spare ? 0 : sizes[k] * (size_t)w->state.count; // spare: scratch
		od_Status status = od_Grow(arrays[k], used, sizes[k] * (size_t)capacity, capacity);
		if (status != OD_OK)
		{
			return status;
		}
	}
	od_Status status = od_MpmGrid_Reserve(w);
	status = status == OD_OK ? od_MpmSort_Reserve(w, capacity) : status;
	if (status == OD_OK)
	{
		w->state.capacity = capacity;
	}
	return status;
}

// Writes the batch after the world's particles (ids count, count + 1, ...) and their fastest speed into
// *maxSpeed, polling for interrupts; the world's count and material table are the caller's to advance.
static od_Status od_CopyParticles(od_MpmWorld* w, const od_MpmParticlesDef* d, double* maxSpeed)
{
	static const double identity[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 }, unit[4] = { 1, 0, 0, 0 };
	for (int i = 0; i < d->count; ++i)
	{
		od_Status status = (i & OD_MPM_ADD_POLL) == 0 ? od_CheckInterrupt() : OD_OK;
		if (status != OD_OK)
		{
			return status;
		}
		int id = w->state.count + i;
		od_MpmParticle* p = &w->state.particles[id];
		*p = (od_MpmParticle){ .Jp = 1.0, .id = id, .material = w->model.materialCount };
		memcpy(p->x, d->positions + 3 * i, sizeof p->x);
		if (d->velocities)
		{
			memcpy(p->v, d->velocities + 3 * i, sizeof p->v);
		}
		if (d->affine)
		{
			memcpy(p->C, d->affine + 9 * i, sizeof p->C);
		}
		memcpy(p->F, identity, sizeof p->F);
		const double* q = d->orientations ? d->orientations + 4 * i : unit;
		double n = 1.0 / sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
		for (int k = 0; k < 4; ++k)
		{
			w->state.quat[4 * id + k] = n * q[k]; // starts at the rest orientation
			w->state.polarQuat[4 * id + k] = unit[k];
		}
		*maxSpeed = fmax(*maxSpeed, od_Length(od_V3Load(p->v)));
	}
	return OD_OK;
}

od_Status od_MpmWorld_AddParticles(od_MpmWorld* w, const od_MpmParticlesDef* d)
{
	od_Status status = od_CheckParticles(w, d);
	if (status != OD_OK)
	{
		return status;
	}
	if (d->count > OD_MPM_MAX_PARTICLES - w->state.count)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "particles: a world holds at most %d particles", OD_MPM_MAX_PARTICLES);
	}
	status = od_MpmWorld_Reserve(w, w->state.count + d->count);
	double maxSpeed = w->state.maxSpeed;
	status = status == OD_OK ? od_CopyParticles(w, d, &maxSpeed) : status;
	if (status != OD_OK)
	{
		return status; // the new particles lie past the count: the world is as it was
	}
	od_MpmMaterialSlot* slot = &w->model.materials[w->model.materialCount];
	*slot = (od_MpmMaterialSlot){ .def = d->material, .volume = d->particleVolume };
	od_MpmMaterial_Derive(slot);
	w->model.materialCount++;
	w->state.count += d->count;
	w->state.maxSpeed = maxSpeed;
	w->state.sinceReorder = OD_MPM_REORDER_EVERY; // sort the newcomers into place at the next substep
	return OD_OK;
}

od_Status od_MpmWorld_SetWind(od_MpmWorld* w, const od_MpmWindDef* def)
{
	return od_MpmWind_Set(&w->model.wind, def, w->model.def.dx);
}

// How far from the domain a collider's frame may be placed, in domain sizes (the box's diagonal): one moved
// 1e300 m was accepted and the next step failed blaming the material (issue 28). Farther than this it touches
// no particle, and a move there (or back) within one step would take more substeps than a call may
// (OD_MPM_MAX_SUBSTEPS: the collider's speed counts in the CFL bound).
#define OD_MPM_COLLIDER_REACH 1e4

static od_Status od_CheckColliderPlace(const od_MpmWorld* w, const double translation[3])
{
	const double* lower = w->model.def.lower;
	const double* upper = w->model.def.upper;
	double size = 0.0, outside = 0.0;
	for (int k = 0; k < 3; ++k)
	{
		size = hypot(size, upper[k] - lower[k]);
		outside = fmax(outside, fmax(lower[k] - translation[k], translation[k] - upper[k]));
	}
	if (!(outside <= OD_MPM_COLLIDER_REACH * size))
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "collider: translation (%g, %g, %g) is %g m outside the domain, more than %g domain sizes (%g m)",
					   translation[0], translation[1], translation[2], outside, OD_MPM_COLLIDER_REACH, size);
	}
	return OD_OK;
}

od_Status od_MpmWorld_AddCollider(od_MpmWorld* w, const od_MpmColliderDef* def, int* id)
{
	od_MpmCollider c;
	od_Status status = od_CheckColliderPlace(w, def->translation);
	if (status != OD_OK)
	{
		return status;
	}
	status = od_MpmCollider_Init(&c, def, w->model.def.dx);
	if (status != OD_OK)
	{
		return status;
	}
	od_MpmCollider* grown = od_Realloc(w->colliders, (size_t)(w->colliderCount + 1) * sizeof *grown);
	if (!grown)
	{
		od_MpmCollider_Destroy(&c);
		return od_Fail(OD_ERROR_MEMORY, "collider: out of memory");
	}
	w->colliders = grown;
	w->colliders[w->colliderCount] = c;
	*id = w->colliderCount++;
	return OD_OK;
}

od_Status od_MpmWorld_MoveCollider(od_MpmWorld* w, int id, const double rotation[9], const double translation[3])
{
	if (id < 0 || id >= w->colliderCount)
	{
		return od_Fail(OD_ERROR_NOT_FOUND, "collider: no collider %d (there are %d)", id, w->colliderCount);
	}
	od_Status status = od_CheckColliderPlace(w, translation);
	if (status != OD_OK)
	{
		return status;
	}
	return od_Collider_SetTarget(&w->colliders[id].body, rotation, translation);
}

// The CFL bound of the next substep.
static double od_CflDt(const od_MpmWorld* w)
{
	double speed = w->state.maxSpeed, wave = 0.0;
	for (int c = 0; c < w->colliderCount; ++c)
	{
		speed = fmax(speed, od_Collider_MaxSpeed(&w->colliders[c].body));
	}
	for (int m = 0; m < w->model.materialCount; ++m)
	{
		double h = w->model.materials[m].def.kind == OD_MPM_SNOW ? w->state.maxHardening : 1.0;
		wave = fmax(wave, od_MpmMaterial_WaveSpeed(&w->model.materials[m], h));
	}
	double dt = w->model.def.cfl * w->model.def.dx / (speed + wave);
	return dt < w->model.def.maxDt ? dt : w->model.def.maxDt;
}

static od_Status od_Advance(od_MpmWorld* w, double dt)
{
	int reorder = w->state.sinceReorder >= OD_MPM_REORDER_EVERY;
	od_Status status = od_MpmGrid_Prepare(w, reorder);
	if (status != OD_OK)
	{
		return status;
	}
	w->state.sinceReorder = reorder ? 1 : w->state.sinceReorder + 1;
	od_MpmP2G(w, dt);
	od_MpmGrid_Update(w, dt);
	od_MpmG2P(w, dt);
	w->state.stats.time += dt;
	w->state.stats.substeps++;
	w->state.stats.lastDt = dt;
	w->state.stats.activeBlocks = w->grid.slotCount;
	w->state.stats.maxSpeed = w->state.maxSpeed;
	if (!isfinite(w->state.maxSpeed))
	{
		return od_Fail(OD_ERROR_NOT_FINITE, "step: a particle velocity became infinite or NaN (time %g s); the "
											"state is no longer usable",
					   w->state.stats.time);
	}
	return OD_OK;
}

static od_Status od_CheckCall(const od_MpmWorld* w, const char* name, double duration)
{
	if (!(duration > 0.0) || !isfinite(duration))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "%s must be > 0 and finite, got %g", name, duration);
	}
	if (w->state.count == 0)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "the world has no particles");
	}
	return OD_OK;
}

static void od_BeginCall(od_MpmWorld* w, double duration)
{
	for (int c = 0; c < w->colliderCount; ++c)
	{
		od_Collider_BeginCall(&w->colliders[c].body, duration);
	}
}

static void od_EndCall(od_MpmWorld* w)
{
	for (int c = 0; c < w->colliderCount; ++c)
	{
		od_Collider_EndCall(&w->colliders[c].body);
	}
}

od_Status od_MpmWorld_Substep(od_MpmWorld* w, double dt)
{
	od_Status status = od_CheckCall(w, "dt", dt);
	if (status != OD_OK)
	{
		return status;
	}
	od_BeginCall(w, dt);
	for (int c = 0; c < w->colliderCount; ++c)
	{
		od_Collider_Place(&w->colliders[c].body, 1.0);
	}
	status = od_Advance(w, dt);
	od_EndCall(w);
	return status;
}

// A Step that would need more substeps than this fails instead of running for hours (a cfl or max_dt far
// too small for the duration): 100,000 substeps are ~4e-7 s each for a frame at 24 fps.
#define OD_MPM_MAX_SUBSTEPS 100000
// ... or more work than this, in particle-substeps: about 90 s of one core (a substep costs 0.69 us a
// particle, measured on the 2-core EPYC with 6,859 snow particles), 50 times a 24 fps frame of 64k
// particles at max_dt. A collider moved 1 km in a 0.01 s step asked 80,000 substeps of 6,859 particles.
#define OD_MPM_MAX_WORK (1 << 27)

static od_Status od_TooManySubsteps(double duration, double dt)
{
	return od_Fail(OD_ERROR_ARGUMENT,
				   "step: %g s needs more than %d substeps of %g s (cfl, max_dt, the material's wave speed or a "
				   "collider's speed); step it in shorter calls",
				   duration, OD_MPM_MAX_SUBSTEPS, dt);
}

// The bounds of a Step call, checked before anything moves with the substep that the colliders' speed over
// the call (set by od_BeginCall) and the material allow.
static od_Status od_CheckWork(const od_MpmWorld* w, double duration)
{
	double dt = od_CflDt(w), substeps = duration / dt;
	if (!(dt > 0.0) || (substeps <= OD_MPM_MAX_SUBSTEPS && substeps * w->state.count <= OD_MPM_MAX_WORK))
	{
		return OD_OK; // a zero substep fails in the loop, as one that becomes zero later
	}
	if (substeps > OD_MPM_MAX_SUBSTEPS)
	{
		return od_TooManySubsteps(duration, dt);
	}
	return od_Fail(OD_ERROR_ARGUMENT,
				   "step: %g s needs about %.0f substeps of %g s for %d particles, more than the %d "
				   "particle-substeps (about 90 s of one core) that one call may take; step it in shorter calls",
				   duration, substeps, dt, w->state.count, OD_MPM_MAX_WORK);
}

od_Status od_MpmWorld_Step(od_MpmWorld* w, double duration)
{
	od_Status status = od_CheckCall(w, "duration", duration);
	if (status != OD_OK)
	{
		return status;
	}
	od_BeginCall(w, duration); // sets the colliders' velocities over the call, moves nothing
	status = od_CheckWork(w, duration);
	if (status != OD_OK)
	{
		return status; // every call sets those velocities afresh: nothing to undo
	}
	double elapsed = 0.0;
	int substeps = 0;
	while (status == OD_OK && elapsed < duration)
	{
		double remaining = duration - elapsed, dt = od_CflDt(w);
		if (!(dt > 0.0) || elapsed + dt == elapsed)
		{
			// an infinite wave speed (stiffness or hardening overflowed) would loop here forever
			status = od_Fail(OD_ERROR_NOT_FINITE, "step: the CFL substep is %g s at time %g s (the material's wave "
												  "speed overflowed); the state is no longer usable",
							 dt, w->state.stats.time);
			break;
		}
		if (substeps == OD_MPM_MAX_SUBSTEPS) // the material sped up: the state stays valid at this time
		{
			status = od_TooManySubsteps(duration, dt);
			break;
		}
		status = od_CheckInterrupt(); // the state stays valid at this time too
		if (status != OD_OK)
		{
			break;
		}
		// even out the end: never leave a sliver of a substep
		dt = remaining <= dt ? remaining : (remaining < 2.0 * dt ? 0.5 * remaining : dt);
		double end = remaining <= dt ? duration : elapsed + dt;
		for (int c = 0; c < w->colliderCount; ++c)
		{
			od_Collider_Place(&w->colliders[c].body, end / duration);
		}
		status = od_Advance(w, dt);
		elapsed = end;
		substeps++;
	}
	od_EndCall(w);
	w->state.stats.lastSubsteps = substeps;
	return status == OD_OK ? od_MpmWorld_UpdateOrientations(w) : status; // stopped there: as at the last substep
}

int od_MpmFieldWidth(od_MpmField field)
{
	static const int widths[7] = { 3, 3, 4, 9, 9, 9, 1 };
	return field >= OD_MPM_POSITIONS && field <= OD_MPM_PLASTIC_J ? widths[field] : 0;
}

void od_MpmWorld_Read(const od_MpmWorld* w, od_MpmField field, double* out)
{
	int width = od_MpmFieldWidth(field);
	if (field == OD_MPM_ORIENTATIONS)
	{
		memcpy(out, w->state.quat, sizeof(double) * 4 * (size_t)w->state.count);
		return;
	}
	if (field == OD_MPM_ROTATIONS)
	{
		for (int i = 0; i < w->state.count; ++i)
		{
			od_Mat3 r = od_QuatToMatrix(w->state.polarQuat + 4 * i);
			od_M3Store(out + 9 * i, &r);
		}
		return;
	}
	for (int i = 0; i < w->state.count; ++i)
	{
		const od_MpmParticle* p = &w->state.particles[i];
		const double* src = field == OD_MPM_POSITIONS	 ? p->x
							: field == OD_MPM_VELOCITIES  ? p->v
							: field == OD_MPM_DEFORMATION ? p->F
							: field == OD_MPM_AFFINE	  ? p->C
														  : &p->Jp;
		memcpy(out + (size_t)width * p->id, src, sizeof(double) * (size_t)width);
	}
}

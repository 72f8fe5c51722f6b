// libFuzzer target: MPM worlds (od_MpmWorld_*) from arbitrary definitions, then a byte-driven sequence of
// particle batches (positions, velocities, APIC matrices, orientations, materials), wind, colliders
// (plane, box, sphere, and triangle meshes with arbitrary indices), collider moves, steps and substeps.
// Invariants: a rejected definition leaves *world NULL; while every call succeeds the particles stay
// finite and inside the domain, the particle count is the sum of the accepted batches and reads of every
// field are finite; after OD_ERROR_NOT_FINITE (documented as the end of a world) only destruction follows.
// Sizes are bounded so that one input stays fast: at most 48 particles a batch, domains of at most
// 2^18 grid blocks are built (larger finite ones are valid but too slow to fuzz; non-finite ones and
// ones beyond int range must be rejected cleanly and are passed through).
#include "fuzz_input.h"

#include "opdeform/mpm.h"

#include <stdlib.h>

#define MAX_BATCH 48
#define MAX_OPS 24

static double fuzz_small_positive(FuzzInput* in, double scale)
{
	return fuzz_byte(in) < 8 ? fuzz_double(in, scale) : scale * (1.0 + fuzz_byte(in)) / 128.0;
}

static od_MpmWorldDef fuzz_world_def(FuzzInput* in)
{
	od_MpmWorldDef d = od_DefaultMpmWorldDef();
	int raw = fuzz_byte(in) < 16;
	for (int a = 0; a < 3; ++a)
	{
		d.lower[a] = raw ? fuzz_double(in, 1.0) : -0.5 + fuzz_int(in, 0, 8) * 0.125;
		d.upper[a] = raw ? fuzz_double(in, 1.0) : d.lower[a] + 0.25 + fuzz_int(in, 0, 12) * 0.125;
	}
	d.dx = raw ? fuzz_double(in, 0.1) : 1.0 / (16 + fuzz_int(in, 0, 48));
	fuzz_vec3(in, 10.0, d.gravity);
	d.cfl = fuzz_byte(in) < 16 ? fuzz_double(in, 1.0) : 0.1 + 0.1 * fuzz_int(in, 0, 9);
	// A tiny positive cfl is valid but makes every step take ~1/cfl substeps (docs/hardening.md, open findings).
	d.cfl = d.cfl > 0.0 && d.cfl < 0.01 ? 0.01 : d.cfl;
	d.maxDt = fuzz_byte(in) < 16 ? fuzz_double(in, 1e-3) : 1e-4 * fuzz_int(in, 1, 20);
	d.maxDt = d.maxDt > 0.0 && d.maxDt < 1e-4 ? 1e-4 : d.maxDt; // valid, but a step would take ~1/maxDt substeps
	d.spin = fuzz_double(in, 1.0);
	d.walls = (od_MpmContact)fuzz_int(in, -1, 3);
	d.wallFriction = fuzz_double(in, 0.5);
	d.threads = fuzz_int(in, -1, 2);
	return d;
}

// Whether a definition that od_MpmWorld_Create may accept is small enough to build here.
static int small_enough(const od_MpmWorldDef* d)
{
	double blocks = 1.0;
	for (int a = 0; a < 3; ++a)
	{
		double cells = (d->upper[a] - d->lower[a]) / d->dx;
		if (!isfinite(cells) || cells > 4e9)
		{
			return 1; // beyond int range or not finite: must be rejected, and that is cheap
		}
		blocks *= cells / 4.0 + 2.0;
	}
	return blocks <= (double)(1 << 18) || blocks > (double)(1u << 31);
}

static od_MpmMaterial fuzz_material(FuzzInput* in)
{
	int kind = fuzz_int(in, -1, 3);
	od_MpmMaterial m = kind == 1 ? od_MpmJellyMaterial() : kind == 2 ? od_MpmFlakeMaterial() : od_MpmSnowMaterial();
	m.kind = (od_MpmMaterialKind)kind;
	if (fuzz_byte(in) < 64)
	{
		m.density = fuzz_positive(in, 1e3);
		m.youngModulus = fuzz_positive(in, 1e4);
		m.poissonRatio = fuzz_double(in, 0.5);
		m.criticalCompression = fuzz_double(in, 0.05);
		m.criticalStretch = fuzz_double(in, 0.01);
		m.hardening = fuzz_double(in, 10.0);
	}
	// Finite but absurd stiffness makes a CFL substep so short that a step takes hours: valid input, but
	// a slow one. Keep the wave speed below ~1e4 m/s unless it is infinite (which Step must reject).
	if (isfinite(m.youngModulus) && isfinite(m.density) && m.density > 0.0 && m.youngModulus / m.density > 1e8 &&
		isfinite(m.youngModulus / m.density))
	{
		m.youngModulus = 1e8 * m.density;
	}
	if (isfinite(m.hardening) && m.hardening > 50.0)
	{
		m.hardening = 50.0;
	}
	return m;
}

static od_Status add_particles(od_MpmWorld* w, const od_MpmWorldDef* wd, FuzzInput* in)
{
	static double x[3 * MAX_BATCH], v[3 * MAX_BATCH], c[9 * MAX_BATCH], q[4 * MAX_BATCH];
	int count = fuzz_int(in, -1, MAX_BATCH);
	int flags = fuzz_byte(in);
	for (int i = 0; i < count; ++i)
	{
		for (int a = 0; a < 3; ++a)
		{
			// mostly inside the domain shrunk by two cells, sometimes anywhere
			double lo = wd->lower[a] + 2.0 * wd->dx, hi = wd->upper[a] - 2.0 * wd->dx;
			x[3 * i + a] = (flags & 1) ? fuzz_double(in, 1.0) : lo + (hi - lo) * fuzz_byte(in) / 255.0;
			v[3 * i + a] = fuzz_double(in, 1.0);
		}
		for (int k = 0; k < 9; ++k)
		{
			c[9 * i + k] = (flags & 4) ? fuzz_double(in, 1.0) : 0.0;
		}
		double r[9];
		fuzz_rotation(in, r);
		double n = 0.0;
		for (int k = 0; k < 4; ++k)
		{
			q[4 * i + k] = (double)(int8_t)fuzz_byte(in);
			n += q[4 * i + k] * q[4 * i + k];
		}
		for (int k = 0; k < 4 && n > 0.0 && !(flags & 16); ++k)
		{
			q[4 * i + k] /= sqrt(n);
		}
	}
	od_MpmParticlesDef d = od_DefaultMpmParticlesDef();
	d.count = count;
	d.positions = (flags & 32) ? NULL : x;
	d.velocities = (flags & 2) ? v : NULL;
	d.affine = (flags & 4) ? c : NULL;
	d.orientations = (flags & 8) ? q : NULL;
	d.particleVolume = fuzz_small_positive(in, wd->dx * wd->dx * wd->dx);
	d.material = fuzz_material(in);
	TRACE("particles %d flags %d volume %.17g material %d rho %.17g E %.17g nu %.17g\n", count, flags,
		  d.particleVolume, (int)d.material.kind, d.material.density, d.material.youngModulus, d.material.poissonRatio);
	for (int i = 0; i < count && fuzz_tracing(); ++i)
	{
		TRACE("  x %.17g %.17g %.17g v %.17g %.17g %.17g\n", x[3 * i], x[3 * i + 1], x[3 * i + 2], v[3 * i], v[3 * i + 1],
			  v[3 * i + 2]);
	}
	return od_MpmWorld_AddParticles(w, &d);
}

static od_Status set_wind(od_MpmWorld* w, FuzzInput* in)
{
	od_MpmWindDef d = od_DefaultMpmWindDef();
	d.kind = (od_MpmWindKind)fuzz_int(in, -1, 3);
	fuzz_vec3(in, 2.0, d.velocity);
	d.amplitude = fuzz_double(in, 2.0);
	d.wavelength = fuzz_positive(in, 1.0);
	d.octaves = fuzz_int(in, -1, 17);
	d.persistence = fuzz_positive(in, 0.5);
	d.drift[0] = fuzz_double(in, 1.0);
	d.drift[1] = fuzz_double(in, 1.0);
	d.drag = fuzz_double(in, 2.0);
	d.ground = fuzz_double(in, 1.0);
	d.refHeight = fuzz_positive(in, 1.0);
	d.exponent = fuzz_double(in, 0.5);
	d.seed = fuzz_u32(in);
	return od_MpmWorld_SetWind(w, &d);
}

static od_Status add_collider(od_MpmWorld* w, FuzzInput* in, int* id)
{
	static double vertices[3 * 12];
	static int triangles[3 * 16];
	od_MpmColliderDef d = od_DefaultMpmColliderDef();
	d.shape = (od_MpmShape)fuzz_int(in, -1, 4);
	d.contact = (od_MpmContact)fuzz_int(in, -1, 3);
	d.friction = fuzz_double(in, 0.5);
	for (int a = 0; a < 3; ++a)
	{
		d.halfExtents[a] = fuzz_positive(in, 0.2);
	}
	fuzz_frame(in, d.rotation);
	fuzz_vec3(in, 0.5, d.translation);
	if (d.shape == OD_MPM_MESH)
	{
		d.vertexCount = fuzz_int(in, -1, 12);
		d.triangleCount = fuzz_int(in, -1, 16);
		for (int i = 0; i < 3 * (d.vertexCount > 0 ? d.vertexCount : 0); ++i)
		{
			vertices[i] = fuzz_double(in, 0.3);
		}
		for (int k = 0; k < 3 * (d.triangleCount > 0 ? d.triangleCount : 0); ++k)
		{
			triangles[k] = fuzz_int(in, -1, d.vertexCount);
		}
		d.vertices = vertices;
		d.triangles = triangles;
	}
	return od_MpmWorld_AddCollider(w, &d, id);
}

static void check_fields(const od_MpmWorld* w, const od_MpmWorldDef* wd)
{
	int n = od_MpmWorld_GetParticleCount(w);
	if (n == 0)
	{
		return;
	}
	double* out = malloc(sizeof(double) * 9 * (size_t)n);
	for (int f = OD_MPM_POSITIONS; f <= OD_MPM_PLASTIC_J; ++f)
	{
		od_MpmWorld_Read(w, (od_MpmField)f, out);
		TRACE("field %d: %g %g %g\n", f, out[0], out[1], out[2]);
		CHECK(fuzz_all_finite(out, (size_t)od_MpmFieldWidth((od_MpmField)f) * n));
		if (f == OD_MPM_POSITIONS)
		{
			for (int i = 0; i < n; ++i)
			{
				for (int a = 0; a < 3; ++a)
				{
					CHECK(out[3 * i + a] >= wd->lower[a] && out[3 * i + a] <= wd->upper[a]);
				}
			}
		}
	}
	free(out);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
	FuzzInput in = { data, size };
	od_MpmWorldDef def = fuzz_world_def(&in);
	if (!small_enough(&def))
	{
		return 0;
	}
	TRACE("world lower (%.17g %.17g %.17g) upper (%.17g %.17g %.17g) dx %.17g gravity (%.17g %.17g %.17g) cfl %.17g "
		  "maxDt %.17g spin %.17g walls %d friction %.17g threads %d\n",
		  def.lower[0], def.lower[1], def.lower[2], def.upper[0], def.upper[1], def.upper[2], def.dx, def.gravity[0],
		  def.gravity[1], def.gravity[2], def.cfl, def.maxDt, def.spin, (int)def.walls, def.wallFriction, def.threads);
	od_MpmWorld* w = (od_MpmWorld*)&in;
	od_Status status = od_MpmWorld_Create(&def, &w);
	TRACE("  -> %s\n", od_StatusName(status));
	if (status != OD_OK)
	{
		CHECK(w == NULL);
		CHECK(status == OD_ERROR_ARGUMENT || status == OD_ERROR_MEMORY);
		return 0;
	}
	od_MpmWorldDef got = od_MpmWorld_GetDef(w);
	CHECK(memcmp(&got, &def, sizeof def) == 0);
	int particles = 0, colliders = 0;
	for (int op = 0; op < MAX_OPS && in.size > 0; ++op)
	{
		int code = fuzz_int(&in, 0, 6);
		int before = od_MpmWorld_GetParticleCount(w);
		switch (code)
		{
			case 0:
			{
				FuzzInput peek = in;
				int count = fuzz_int(&peek, -1, MAX_BATCH);
				status = add_particles(w, &def, &in);
				CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT);
				particles += status == OD_OK ? count : 0;
				break;
			}
			case 1:
				status = set_wind(w, &in);
				CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT);
				break;
			case 2:
			{
				int id = -1;
				status = add_collider(w, &in, &id);
				CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT);
				if (status == OD_OK)
				{
					CHECK(id == colliders);
					colliders++;
				}
				break;
			}
			case 3:
			{
				double r[9], t[3];
				fuzz_frame(&in, r);
				fuzz_vec3(&in, 0.2, t);
				status = od_MpmWorld_MoveCollider(w, fuzz_int(&in, -1, colliders), r, t);
				CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT || status == OD_ERROR_NOT_FOUND);
				break;
			}
			case 4:
			case 5:
			{
				double t = fuzz_small_positive(&in, code == 4 ? 1e-3 : 2e-3);
				// A step runs duration / Δt substeps: any finite duration is valid, long ones are just slow.
				t = code == 5 && isfinite(t) && t > 0.01 ? 0.01 : t;
				TRACE("%s %.17g\n", code == 4 ? "substep" : "step", t);
				status = code == 4 ? od_MpmWorld_Substep(w, t) : od_MpmWorld_Step(w, t);
				break;
			}
			default:
				od_MpmWorld_UpdateOrientations(w);
				status = OD_OK;
				break;
		}
		TRACE("op %d -> %s %s (particles %d)\n", code, od_StatusName(status), status ? od_GetErrorMessage() : "",
			  od_MpmWorld_GetParticleCount(w));
		if (status != OD_OK)
		{
			CHECK(status != OD_ERROR_BUSY && status != OD_ERROR_INTERNAL);
			CHECK(od_MpmWorld_GetParticleCount(w) == before);
		}
		if (status == OD_ERROR_NOT_FINITE)
		{
			break; // the documented end of a world: only destruction may follow
		}
		CHECK(od_MpmWorld_GetParticleCount(w) == particles);
		if (status == OD_OK && (code == 4 || code == 5))
		{
			check_fields(w, &def);
		}
	}
	od_MpmWorld_Destroy(w);
	return 0;
}

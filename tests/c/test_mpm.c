// MPM: B-spline moments, exact transfers (affine fields, linear and angular momentum with the affine
// term), the snow clamp, curl-free wind, mesh distances, determinism across thread counts and no
// allocation per substep after warm-up.
#include "world.h"
#include "polar.h"
#include "test_macros.h"

static od_MpmWorld* make_world(int threads, double dx)
{
	od_MpmWorldDef def = od_DefaultMpmWorldDef();
	def.dx = dx;
	def.threads = threads;
	def.gravity[2] = 0.0;
	od_MpmWorld* w = NULL;
	return od_MpmWorld_Create(&def, &w) == OD_OK ? w : NULL;
}

// n random particles in [0.3, 0.7]³ with velocity a + B x and C = B when affine, random v and C otherwise.
static int add_particles(od_MpmWorld* w, int n, int affine, od_MpmMaterial material, unsigned long long seed)
{
	double x[3 * 400], v[3 * 400], c[9 * 400], B[9], a[3];
	for (int k = 0; k < 9; ++k)
	{
		B[k] = 2.0 * test_random(&seed) - 1.0;
	}
	for (int k = 0; k < 3; ++k)
	{
		a[k] = 2.0 * test_random(&seed) - 1.0;
	}
	for (int i = 0; i < n; ++i)
	{
		for (int k = 0; k < 3; ++k)
		{
			x[3 * i + k] = 0.3 + 0.4 * test_random(&seed);
		}
		for (int r = 0; r < 3; ++r)
		{
			v[3 * i + r] = affine ? a[r] + B[3 * r] * x[3 * i] + B[3 * r + 1] * x[3 * i + 1] + B[3 * r + 2] * x[3 * i + 2]
								  : 2.0 * test_random(&seed) - 1.0;
		}
		for (int k = 0; k < 9; ++k)
		{
			c[9 * i + k] = affine ? B[k] : 2.0 * test_random(&seed) - 1.0;
		}
	}
	od_MpmParticlesDef def = od_DefaultMpmParticlesDef();
	def.count = n;
	def.positions = x;
	def.velocities = v;
	def.affine = c;
	def.particleVolume = 1e-6;
	def.material = material;
	return od_MpmWorld_AddParticles(w, &def) == OD_OK;
}

static int test_bspline_moments(void)
{
	od_MpmWorld* w = make_world(1, 0.05);
	ENSURE(w);
	unsigned long long seed = 7;
	double dx = 0.05;
	for (int trial = 0; trial < 200; ++trial)
	{
		double x[3] = { 0.2 + 0.6 * test_random(&seed), 0.2 + 0.6 * test_random(&seed), 0.2 + 0.6 * test_random(&seed) };
		od_MpmStencil s;
		od_MpmStencil_Make(w, x, &s);
		double sum = 0.0, first[3] = { 0 }, second[9] = { 0 };
		for (int k = 0; k < 27; ++k)
		{
			int o[3] = { k % 3, (k / 3) % 3, k / 9 };
			double wt = s.w[0][o[0]] * s.w[1][o[1]] * s.w[2][o[2]], d[3];
			for (int a = 0; a < 3; ++a)
			{
				d[a] = (s.base[a] + o[a]) * dx - x[a]; // node - particle (lower = 0)
				first[a] += wt * d[a];
			}
			for (int r = 0; r < 9; ++r)
			{
				second[r] += wt * d[r / 3] * d[r % 3];
			}
			sum += wt;
		}
		ENSURE_SMALL(sum - 1.0, 1e-14);
		for (int a = 0; a < 3; ++a)
		{
			ENSURE_SMALL(first[a], 1e-15);
		}
		for (int r = 0; r < 9; ++r)
		{
			ENSURE_SMALL(second[r] - (r % 4 == 0 ? dx * dx / 4.0 : 0.0), 1e-16);
		}
	}
	od_MpmWorld_Destroy(w);
	return 0;
}

// Particle momentum and angular momentum, the latter with APIC's affine term m Δx²/4 axial(Cᵀ − C).
static void particle_momenta(const od_MpmWorld* w, double p[3], double l[3])
{
	double q = 0.25 / (w->model.invDx * w->model.invDx);
	for (int a = 0; a < 3; ++a)
	{
		p[a] = l[a] = 0.0;
	}
	for (int i = 0; i < w->state.count; ++i)
	{
		const od_MpmParticle* pt = &w->state.particles[i];
		double m = w->model.materials[pt->material].mass;
		od_Vec3 lx = od_Scale(m, od_Cross(od_V3Load(pt->x), od_V3Load(pt->v)));
		const double* C = pt->C;
		double aff[3] = { C[7] - C[5], C[2] - C[6], C[3] - C[1] };
		for (int a = 0; a < 3; ++a)
		{
			p[a] += m * pt->v[a];
			l[a] += (&lx.x)[a] + m * q * aff[a];
		}
	}
}

// Grid momentum and angular momentum; velocities (after the grid update) or momenta (after P2G).
static void grid_momenta(const od_MpmWorld* w, int velocities, double p[3], double l[3])
{
	for (int a = 0; a < 3; ++a)
	{
		p[a] = l[a] = 0.0;
	}
	const od_MpmGrid* g = &w->grid;
	for (int s = 0; s < g->slotCount; ++s)
	{
		int block = g->blockOfSlot[s];
		int b[3] = { block % g->blocks[0], (block / g->blocks[0]) % g->blocks[1], block / (g->blocks[0] * g->blocks[1]) };
		for (int i = 0; i < 64; ++i)
		{
			const double* node = g->nodes + ((size_t)s * 64 + i) * 4;
			od_Vec3 x = od_V3((4 * b[0] + (i & 3)) / w->model.invDx, (4 * b[1] + ((i >> 2) & 3)) / w->model.invDx,
							  (4 * b[2] + (i >> 4)) / w->model.invDx);
			od_Vec3 mv = velocities ? od_Scale(node[3], od_V3Load(node)) : od_V3Load(node);
			od_Vec3 lx = od_Cross(x, mv);
			for (int a = 0; a < 3; ++a)
			{
				p[a] += (&mv.x)[a];
				l[a] += (&lx.x)[a];
			}
		}
	}
}

static int same3(const double a[3], const double b[3], double tol)
{
	for (int k = 0; k < 3; ++k)
	{
		if (!(fabs(a[k] - b[k]) <= tol))
		{
			printf("  %g %g %g vs %g %g %g\n", a[0], a[1], a[2], b[0], b[1], b[2]);
			return 0;
		}
	}
	return 1;
}

// One transfer round trip with dt = 0 (no stress, no motion): conservation in both directions.
static int test_transfer_conservation(void)
{
	od_MpmWorld* w = make_world(2, 0.05);
	ENSURE(w && add_particles(w, 300, 0, od_MpmJellyMaterial(), 11));
	double p0[3], l0[3], pg[3], lg[3], p1[3], l1[3];
	particle_momenta(w, p0, l0);
	ENSURE(od_MpmGrid_Prepare(w, 1) == OD_OK);
	od_MpmP2G(w, 0.0);
	grid_momenta(w, 0, pg, lg);
	ENSURE(same3(p0, pg, 1e-13) && same3(l0, lg, 1e-13));
	od_MpmGrid_Update(w, 0.0);
	od_MpmG2P(w, 0.0);
	grid_momenta(w, 1, pg, lg);
	particle_momenta(w, p1, l1);
	ENSURE(same3(p1, pg, 1e-13) && same3(l1, lg, 1e-13));
	od_MpmWorld_Destroy(w);
	return 0;
}

static int test_affine_reproduction(void)
{
	od_MpmWorld* w = make_world(2, 0.05);
	ENSURE(w && add_particles(w, 400, 1, od_MpmJellyMaterial(), 5));
	double v0[3 * 400], c0[9 * 400], v1[3 * 400], c1[9 * 400];
	od_MpmWorld_Read(w, OD_MPM_VELOCITIES, v0);
	od_MpmWorld_Read(w, OD_MPM_AFFINE, c0);
	ENSURE(od_MpmGrid_Prepare(w, 1) == OD_OK);
	od_MpmP2G(w, 0.0);
	od_MpmGrid_Update(w, 0.0);
	od_MpmG2P(w, 0.0);
	od_MpmWorld_Read(w, OD_MPM_VELOCITIES, v1);
	od_MpmWorld_Read(w, OD_MPM_AFFINE, c1);
	double ev = 0.0, ec = 0.0;
	for (int k = 0; k < 3 * 400; ++k)
	{
		ev = fmax(ev, fabs(v1[k] - v0[k]));
	}
	for (int k = 0; k < 9 * 400; ++k)
	{
		ec = fmax(ec, fabs(c1[k] - c0[k]));
	}
	ENSURE_SMALL(ev, 1e-13);
	ENSURE_SMALL(ec, 1e-11);
	od_MpmWorld_Destroy(w);
	return 0;
}

static int test_snow_clamp(void)
{
	od_MpmMaterialSlot slot = { .def = od_MpmSnowMaterial(), .volume = 1e-6 };
	od_MpmMaterial_Derive(&slot);
	unsigned long long seed = 3;
	for (int trial = 0; trial < 500; ++trial)
	{
		od_MpmParticle p = { .Jp = 0.5 + test_random(&seed) };
		for (int k = 0; k < 9; ++k)
		{
			p.F[k] = (k % 4 == 0) + 0.2 * (2.0 * test_random(&seed) - 1.0);
		}
		od_Mat3 before = od_M3Load(p.F);
		double jBefore = od_M3Det(&before) * p.Jp;
		od_Mat3 u0, v0;
		od_Vec3 s0;
		od_Svd3(&before, &u0, &s0, &v0);
		double h = od_MpmMaterial_Update(&slot, &p, &u0, s0, &v0);
		od_Mat3 after = od_M3Load(p.F), u, v;
		od_Vec3 s;
		od_Svd3(&after, &u, &s, &v);
		ENSURE(s.x <= 1.0 + slot.def.criticalStretch + 1e-12 && s.z >= 1.0 - slot.def.criticalCompression - 1e-12);
		ENSURE_SMALL(od_M3Det(&after) * p.Jp - jBefore, 1e-12); // total volume change kept
		ENSURE_SMALL(h - exp(10.0 * (1.0 - p.Jp)), 1e-12 * h);
		// the rotation is untouched by the clamp
		od_Mat3 r0 = od_PolarRotation(&before), r1 = od_PolarRotation(&after);
		for (int k = 0; k < 9; ++k)
		{
			ENSURE_SMALL(r0.m[k] - r1.m[k], 1e-10);
		}
	}
	return 0;
}

static int test_wind_curl(void)
{
	od_MpmWind wind;
	od_MpmWindDef def = od_DefaultMpmWindDef();
	double curl[2] = { 0, 0 };
	for (int kind = 0; kind < 2; ++kind)
	{
		def.kind = kind == 0 ? OD_MPM_WIND_POTENTIAL : OD_MPM_WIND_NOISE;
		def.wavelength = 1.0;
		ENSURE(od_MpmWind_Set(&wind, &def, 0.05) == OD_OK);
		unsigned long long seed = 9;
		double e = 1e-5;
		for (int trial = 0; trial < 100; ++trial)
		{
			od_Vec3 x = od_V3(3 * test_random(&seed), 3 * test_random(&seed), 1.0);
			od_Vec3 vxp = od_MpmWind_Velocity(&wind, od_V3(x.x + e, x.y, x.z), 0.3);
			od_Vec3 vxm = od_MpmWind_Velocity(&wind, od_V3(x.x - e, x.y, x.z), 0.3);
			od_Vec3 vyp = od_MpmWind_Velocity(&wind, od_V3(x.x, x.y + e, x.z), 0.3);
			od_Vec3 vym = od_MpmWind_Velocity(&wind, od_V3(x.x, x.y - e, x.z), 0.3);
			curl[kind] = fmax(curl[kind], fabs((vxp.y - vxm.y) - (vyp.x - vym.x)) / (2 * e));
		}
	}
	ENSURE_SMALL(curl[0], 1e-6);
	ENSURE(curl[1] > 0.5);
	return 0;
}

static int test_mesh_distance(void)
{
	// a unit cube of 12 triangles, outward winding
	static const double v[24] = { -0.5, -0.5, -0.5, 0.5, -0.5, -0.5, 0.5, 0.5, -0.5, -0.5, 0.5, -0.5,
								  -0.5, -0.5, 0.5,	0.5, -0.5, 0.5,	 0.5, 0.5, 0.5,	  -0.5, 0.5, 0.5 };
	static const int t[36] = { 0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
							   2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3 };
	od_MpmColliderDef def = od_DefaultMpmColliderDef();
	def.shape = OD_MPM_MESH;
	def.vertexCount = 8;
	def.vertices = v;
	def.triangleCount = 12;
	def.triangles = t;
	od_MpmCollider c;
	ENSURE(od_MpmCollider_Init(&c, &def, 0.05) == OD_OK);
	od_Vec3 inside = od_MpmCollider_Node(&c, od_V3(0.1, 0.2, 0.45), od_V3(0, 0, -1)); // moving into the top
	ENSURE_SMALL(inside.z, 1e-12);
	od_Vec3 outside = od_MpmCollider_Node(&c, od_V3(0.1, 0.2, 0.6), od_V3(0, 0, -1));
	ENSURE_SMALL(outside.z + 1.0, 1e-12);
	od_Vec3 x = od_V3(0.1, -0.2, 0.4), vel = od_V3(0, 0, -1);
	od_MpmCollider_Particle(&c, &x, &vel);
	ENSURE_SMALL(x.z - 0.5, 0.01); // pushed out through the nearest face
	ENSURE_SMALL(vel.z, 1e-12);
	od_MpmCollider_Destroy(&c);
	def.triangleCount = 0;
	ENSURE(od_MpmCollider_Init(&c, &def, 0.05) == OD_ERROR_ARGUMENT);
	return 0;
}

// Snow falling onto the floor with wind: bit-identical with 1 and 2 threads.
static int run_snow(int threads, double* out)
{
	od_MpmWorld* w = make_world(threads, 0.04);
	ENSURE(w);
	w->model.def.gravity[2] = -9.81;
	ENSURE(add_particles(w, 400, 0, od_MpmSnowMaterial(), 21));
	od_MpmWindDef wind = od_DefaultMpmWindDef();
	wind.kind = OD_MPM_WIND_NOISE;
	ENSURE(od_MpmWorld_SetWind(w, &wind) == OD_OK);
	od_MpmColliderDef floor = od_DefaultMpmColliderDef();
	floor.translation[2] = 0.2;
	int id;
	ENSURE(od_MpmWorld_AddCollider(w, &floor, &id) == OD_OK);
	ENSURE(od_MpmWorld_Step(w, 0.1) == OD_OK);
	od_MpmWorld_Read(w, OD_MPM_POSITIONS, out);
	od_MpmWorld_Destroy(w);
	return 0;
}

static int test_determinism(void)
{
	static double a[1200], b[1200];
	ENSURE(run_snow(1, a) == 0 && run_snow(2, b) == 0);
	for (int k = 0; k < 1200; ++k)
	{
		ENSURE(a[k] == b[k]);
	}
	return 0;
}

// Once the grid has grown to the region the material occupies, substeps allocate nothing.
static int test_no_allocation(void)
{
	od_MpmWorld* w = make_world(2, 0.04);
	ENSURE(w && add_particles(w, 400, 0, od_MpmJellyMaterial(), 4));
	ENSURE(od_MpmWorld_Step(w, 0.01) == OD_OK);
	long long before = od_GetAllocationCount();
	ENSURE(od_MpmWorld_Step(w, 0.01) == OD_OK);
	ENSURE(od_GetAllocationCount() == before);
	ENSURE(od_MpmWorld_GetStats(w).lastSubsteps > 1);
	od_MpmWorld_Destroy(w);
	return 0;
}

int test_mpm(void)
{
	ENSURE(test_bspline_moments() == 0);
	ENSURE(test_transfer_conservation() == 0);
	ENSURE(test_affine_reproduction() == 0);
	ENSURE(test_snow_clamp() == 0);
	ENSURE(test_wind_curl() == 0);
	ENSURE(test_mesh_distance() == 0);
	ENSURE(test_determinism() == 0);
	ENSURE(test_no_allocation() == 0);
	return 0;
}

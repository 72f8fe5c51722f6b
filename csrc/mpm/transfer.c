// Particle-grid transfers of MLS-MPM with APIC (Hu et al. 2018, Jiang et al. 2015), quadratic B-splines.
//
// Design: both transfers work block by block on a 6³ region of nodes kept in the thread's scratch: P2G
// scatters every particle of an occupied block into the region and then adds the region into the grid
// (colour by colour, see grid.c); G2P copies the region out of the grid and gathers from it. With
// D⁻¹ = 4/Δx², P2G adds w (m v + (m C − Δt V D⁻¹ τ)(xᵢ − x)) and w m to each of the 27 nodes; G2P takes
// v = Σ w vᵢ and C = D⁻¹ Σ w vᵢ (xᵢ − x)ᵀ, moves the particle, updates F ← (I + Δt C) F and runs the
// material's plasticity and stress (material.c), whose τ the next P2G scatters. G2P takes a block's particles
// OD_MPM_SVD_BATCH at a time: the gathers first, then the batch's SVDs together (od_Svd3Many: eight at a time in
// AVX2 registers where the processor has them, the same bits as one by one), then the material of each.
#include "world.h"

#include "polar.h"

#include <string.h>

void od_MpmStencil_Make(const od_MpmWorld* w, const double x[3], od_MpmStencil* s)
{
	for (int a = 0; a < 3; ++a)
	{
		double g = (x[a] - w->model.def.lower[a]) * w->model.invDx;
		s->base[a] = (int)floor(g - 0.5);
		double f = g - s->base[a];
		s->fx[a] = f;
		s->w[a][0] = 0.5 * (1.5 - f) * (1.5 - f);
		s->w[a][1] = 0.75 - (f - 1.0) * (f - 1.0);
		s->w[a][2] = 0.5 * (f - 0.5) * (f - 0.5);
	}
}

static double* od_RegionNode(double* region, const int local[3], int i, int j, int k)
{
	return region + ((((local[2] + k) * OD_MPM_REGION) + local[1] + j) * OD_MPM_REGION + local[0] + i) * 4;
}

typedef struct od_TransferJob
{
	od_MpmWorld* w;
	double dt;
	int colourStart; // P2G: first entry of the colour in byColour
} od_TransferJob;

static void od_P2GTask(void* ctx, int task, int thread)
{
	const od_TransferJob* job = ctx;
	od_MpmWorld* w = job->w;
	int ob = w->sort.byColour[job->colourStart + task], origin[3];
	double* region = w->threadData[thread].region;
	memset(region, 0, sizeof w->threadData[thread].region);
	od_MpmGrid_RegionOrigin(w, ob, origin);
	double dinv = 4.0 * w->model.invDx * w->model.invDx, dx = 1.0 / w->model.invDx;
	for (int k = w->sort.occupiedStart[ob]; k < w->sort.occupiedStart[ob + 1]; ++k)
	{
		const od_MpmParticle* p = &w->state.particles[w->sort.order[k]];
		const od_MpmMaterialSlot* mat = &w->model.materials[p->material];
		od_MpmStencil s;
		od_MpmStencil_Make(w, p->x, &s);
		int local[3] = { s.base[0] - origin[0], s.base[1] - origin[1], s.base[2] - origin[2] };
		// A = m C − Δt V D⁻¹ τ
		double m = mat->mass, st = -job->dt * mat->volume * dinv, A[9];
		const double* t = p->tau;
		const double tau[9] = { t[0], t[3], t[4], t[3], t[1], t[5], t[4], t[5], t[2] };
		for (int e = 0; e < 9; ++e)
		{
			A[e] = m * p->C[e] + st * tau[e];
		}
		// m v + A (xᵢ − x) = m v + A_x dx + A_y dy + A_z dz: the three terms per offset, once per particle
		double term[3][3][3]; // [axis][offset][component]
		for (int a = 0; a < 3; ++a)
		{
			for (int o = 0; o < 3; ++o)
			{
				double d = (o - s.fx[a]) * dx;
				for (int c = 0; c < 3; ++c)
				{
					term[a][o][c] = A[3 * c + a] * d + (a == 0 ? m * p->v[c] : 0.0);
				}
			}
		}
		for (int kk = 0; kk < 3; ++kk)
		{
			for (int j = 0; j < 3; ++j)
			{
				double wyz = s.w[1][j] * s.w[2][kk];
				double yz[3] = { term[1][j][0] + term[2][kk][0], term[1][j][1] + term[2][kk][1],
								 term[1][j][2] + term[2][kk][2] };
				for (int i = 0; i < 3; ++i)
				{
					double wt = s.w[0][i] * wyz;
					double* node = od_RegionNode(region, local, i, j, kk);
					node[0] += wt * (term[0][i][0] + yz[0]);
					node[1] += wt * (term[0][i][1] + yz[1]);
					node[2] += wt * (term[0][i][2] + yz[2]);
					node[3] += wt * m;
				}
			}
		}
	}
	od_MpmGrid_Flush(w, ob, region);
}

// A particle on one thread, in nanoseconds, scattered and gathered: the pool's measures of the work
// (docs/speed.md; a colour's particles counted as its share of the blocks).
#define OD_P2G_NS 70.0
#define OD_G2P_NS 350.0

void od_MpmP2G(od_MpmWorld* w, double dt)
{
	double perBlock = OD_P2G_NS * w->state.count / (w->sort.occupiedCount > 0 ? w->sort.occupiedCount : 1);
	for (int c = 0; c < 8; ++c)
	{
		od_TransferJob job = { w, dt, w->sort.colourStart[c] };
		int blocks = w->sort.colourStart[c + 1] - w->sort.colourStart[c];
		od_Pool_Run(w->pool, blocks, perBlock * blocks, od_P2GTask, &job);
	}
}

// Keeps a particle one cell inside the domain; the walls' contact rule applies to its velocity there.
static void od_KeepInside(const od_MpmWorld* w, od_Vec3* x, od_Vec3* v)
{
	double dx = 1.0 / w->model.invDx;
	double xs[3]; // by index through an array: x->x's address indexed past x is undefined
	od_V3Store(xs, *x);
	for (int a = 0; a < 3; ++a)
	{
		double lo = w->model.def.lower[a] + dx, hi = w->model.def.lower[a] + (w->grid.cells[a] - 1) * dx;
		if (xs[a] < lo || xs[a] > hi)
		{
			double n[3] = { 0, 0, 0 };
			n[a] = xs[a] < lo ? 1.0 : -1.0;
			xs[a] = xs[a] < lo ? lo : hi;
			*v = od_MpmContactResponse(w->model.def.walls, w->model.def.wallFriction, *v, od_V3Load(n));
		}
	}
	*x = od_V3Load(xs);
}

// G2P's gather for one particle: its velocity and C from the region, the move (colliders, walls), and
// F ← (I + Δt C) F, also left in *F for the batch's SVD.
static void od_G2PMove(const od_MpmWorld* w, double* region, const int origin[3], double dt, od_MpmParticle* p,
					   od_Mat3* F)
{
	double dinv = 4.0 * w->model.invDx * w->model.invDx, dx = 1.0 / w->model.invDx;
	od_MpmStencil s;
	od_MpmStencil_Make(w, p->x, &s);
	int local[3] = { s.base[0] - origin[0], s.base[1] - origin[1], s.base[2] - origin[2] };
	od_Vec3 v = od_V3(0, 0, 0);
	od_Mat3 B = od_M3Zero();
	for (int kk = 0; kk < 3; ++kk)
	{
		for (int j = 0; j < 3; ++j)
		{
			double wyz = s.w[1][j] * s.w[2][kk];
			for (int i = 0; i < 3; ++i)
			{
				const double* node = od_RegionNode(region, local, i, j, kk);
				od_Vec3 vi = od_V3Load(node);
				double wt = s.w[0][i] * wyz;
				v = od_MulAdd(v, wt, vi);
				od_M3AddOuter(&B, wt, vi, od_V3((i - s.fx[0]) * dx, (j - s.fx[1]) * dx, (kk - s.fx[2]) * dx));
			}
		}
	}
	od_Vec3 x = od_MulAdd(od_V3Load(p->x), dt, v);
	for (int c = 0; c < w->colliderCount; ++c)
	{
		od_MpmCollider_Particle(&w->colliders[c], &x, &v);
	}
	od_KeepInside(w, &x, &v);
	od_V3Store(p->x, x);
	od_V3Store(p->v, v);
	// C = D⁻¹ B; F ← (I + Δt C) F
	od_Mat3 C = B, G;
	for (int e = 0; e < 9; ++e)
	{
		C.m[e] *= dinv;
		G.m[e] = (e % 4 == 0) + dt * C.m[e];
	}
	od_M3Store(p->C, &C);
	od_Mat3 F0 = od_M3Load(p->F);
	*F = od_M3Mul(&G, &F0);
	od_M3Store(p->F, F);
}

// The material's plasticity and stress from the particle's SVD, then the thread's reductions.
static void od_G2PMaterial(const od_MpmWorld* w, od_MpmThreadData* td, od_MpmParticle* p, int b)
{
	double h = od_MpmMaterial_Update(&w->model.materials[p->material], p, &td->svd.U[b], td->svd.s[b], &td->svd.V[b]);
	double speed = od_Length(od_V3Load(p->v)), health = p->Jp * 0.0;
	for (int e = 0; e < 9; ++e)
	{
		health += p->F[e] * 0.0 + p->C[e] * 0.0; // NaN or infinity in F or C (a huge Δt) fails the step too
	}
	td->maxSpeed = fmax(td->maxSpeed, isfinite(speed + health) ? speed : INFINITY);
	td->maxHardening = fmax(td->maxHardening, h);
}

// The block's particles a batch at a time: gather and move each, the batch's SVDs together, then the material.
static void od_G2PTask(void* ctx, int ob, int thread)
{
	const od_TransferJob* job = ctx;
	od_MpmWorld* w = job->w;
	od_MpmThreadData* td = &w->threadData[thread];
	int origin[3];
	od_MpmGrid_RegionOrigin(w, ob, origin);
	od_MpmGrid_Load(w, ob, td->region);
	int end = w->sort.occupiedStart[ob + 1];
	for (int first = w->sort.occupiedStart[ob]; first < end; first += OD_MPM_SVD_BATCH)
	{
		int count = end - first < OD_MPM_SVD_BATCH ? end - first : OD_MPM_SVD_BATCH;
		for (int b = 0; b < count; ++b)
		{
			od_G2PMove(w, td->region, origin, job->dt, &w->state.particles[w->sort.order[first + b]], &td->svd.F[b]);
		}
		od_Svd3Many(count, td->svd.F, td->svd.U, td->svd.s, td->svd.V);
		for (int b = 0; b < count; ++b)
		{
			od_G2PMaterial(w, td, &w->state.particles[w->sort.order[first + b]], b);
		}
	}
}

void od_MpmG2P(od_MpmWorld* w, double dt)
{
	int threads = od_Pool_Threads(w->pool);
	for (int t = 0; t < threads; ++t)
	{
		w->threadData[t].maxSpeed = 0.0;
		w->threadData[t].maxHardening = 0.0;
	}
	od_TransferJob job = { w, dt, 0 };
	od_Pool_Run(w->pool, w->sort.occupiedCount, OD_G2P_NS * w->state.count, od_G2PTask, &job);
	w->state.maxSpeed = 0.0;
	w->state.maxHardening = 0.0;
	for (int t = 0; t < threads; ++t)
	{
		w->state.maxSpeed = fmax(w->state.maxSpeed, w->threadData[t].maxSpeed);
		w->state.maxHardening = fmax(w->state.maxHardening, w->threadData[t].maxHardening);
	}
}

// The objective of a step (METHOD.md): elastic energy integrated over the ellipsoids, the inertia of
// variational implicit Euler (or the potential of gravity for a static pose) and the constraints; the prediction
// with its damping per particle.
#include "energy.h"

#include "constraints.h"
#include "core.h"
#include "field.h"
#include "goal.h"
#include "math3.h"

// The predicted centre in the force fields (fields/field.c): the damped velocity `kept` gains h (g + f) and the
// fields' drag D acts implicitly, y = x + h (kept + h (g + f)) / (1 + h D).
static od_Vec3 od_PredictInFields(const od_Sim* sim, od_Vec3 x, od_Vec3 kept)
{
	double h = sim->def.dt, drag;
	od_Vec3 f;
	od_FieldSet_Sample(&sim->fields, x, &f, &drag);
	od_Vec3 gained = od_MulAdd(kept, h, od_Add(od_V3Load(sim->def.gravity), f));
	return od_MulAdd(x, h / (1.0 + h * drag), gained);
}

// The prediction y = x + h (1 - c) v + h² g, R̃ = R + h (1 - c) [ω]× R with c = c_i (od_Damping). With goals
// carrying the rest only the motion relative to the goals is damped, so that a body riding a moving goal is
// not held back: y = x + h (u + (1 - c)(exp(h [Ω]×) v - u)) + h² g and R̃ = R + h [Ω + (1 - c)(ω - Ω)]× R with
// the goal's velocity u over the step and angular velocity Ω (od_Goals_StepVelocity): the velocity relative to
// the goal turns with it, so that a body riding a turning goal keeps riding it.
void od_Predict(od_Sim* sim)
{
	const od_State* s = &sim->state;
	const od_Goals* goals = &sim->goals;
	bool relative = od_Goals_CarryRest(sim);
	double h = sim->def.dt, inertia = sim->def.density / (h * h);
	od_Vec3 g = od_V3Load(sim->def.gravity);
	for (int i = 0; i < sim->graph->n; ++i)
	{
		double c = od_Damping(sim, i), keep = (1.0 - c) * h, turn = keep;
		od_Vec3 x = od_V3Load(s->x + 3 * i), v = od_V3Load(s->v + 3 * i), w = od_V3Load(s->omega + 3 * i);
		od_Vec3 u = od_V3(0, 0, 0), from = x;
		if (relative)
		{
			od_Vec3 spin = od_V3Load(goals->spin + 3 * i);
			od_Mat3 step = od_M3ExpSkew(od_Scale(h, spin));
			u = od_Goals_StepVelocity(sim, i);
			from = od_MulAdd(x, h, u);
			v = od_Sub(od_M3MulV(&step, v), u); // the relative velocity turned with the goal
			w = od_MulAdd(od_Scale(h, spin), keep, od_Sub(w, spin)); // the whole turn of the step
			turn = 1.0;
		}
		od_Vec3 kept = relative ? od_MulAdd(u, 1.0 - c, v) : od_Scale(1.0 - c, v); // for the fields
		od_V3Store(sim->y + 3 * i, sim->fields.count ? od_PredictInFields(sim, x, kept)
													 : od_MulAdd(od_MulAdd(from, keep, v), h * h, g));
		od_Mat3 r = od_M3Load(s->R + 9 * i);
		od_Mat3 wx = od_M3Skew(w);
		od_Mat3 wr = od_M3Mul(&wx, &r);
		od_M3AddScaled(&r, turn, &wr);
		od_M3Store(sim->Rtilde + 9 * i, &r);
		od_Mat3 a = od_M3Load(sim->graph->moments + 9 * i);
		od_Mat3 ra = od_M3Mul(&r, &a);
		for (int k = 0; k < 9; ++k)
		{
			sim->inertiaTerm[9 * i + k] = inertia * ra.m[k];
		}
	}
	sim->predictionValid = true;
}

od_Status od_Sim_SetParticleDamping(od_Sim* sim, const double* damping)
{
	int n = sim->graph->n;
	for (int i = 0; damping && i < n; ++i)
	{
		if (!(damping[i] >= 0.0 && damping[i] <= 1.0))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "damping[%d] = %g must be in [0, 1]", i, damping[i]);
		}
	}
	if (!damping)
	{
		od_Free(sim->damping);
		sim->damping = NULL;
		return OD_OK;
	}
	if (!sim->damping && !(sim->damping = od_Alloc(sizeof(double) * (size_t)n)))
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the damping of %d particles", n);
	}
	memcpy(sim->damping, damping, sizeof(double) * (size_t)n);
	return OD_OK;
}

const double* od_Sim_GetParticleDamping(const od_Sim* sim)
{
	return sim->damping;
}

// tr(D Ā Dᵀ) = ‖D Ē √A‖F² for D = a - b.
static double od_MomentNorm(const od_Mat3* a, const od_Mat3* b, const od_Mat3* moment)
{
	od_Mat3 d = *a;
	od_M3AddScaled(&d, -1.0, b);
	od_Mat3 da = od_M3Mul(&d, moment);
	return od_M3Inner(&da, &d);
}

static double od_ElasticEnergy(const od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	const od_State* s = &sim->state;
	double e = 0.0;
	for (int i = 0; i < g->n; ++i)
	{
		od_Mat3 ri = od_M3Load(s->R + 9 * i);
		od_Vec3 xi = od_V3Load(s->x + 3 * i), ci = od_V3Load(g->centers + 3 * i);
		for (int k = g->adjStart[i]; k < g->adjStart[i + 1]; ++k)
		{
			int j = g->adj[k];
			od_Mat3 rj = od_M3Load(s->R + 9 * j), aj = od_M3Load(g->moments + 9 * j), turned = ri;
			od_Vec3 dbar;
			if (od_Goals_CarryRest(sim)) // R_i Q_ij and d_ij of the goal shape, as the edge's terms keep them (goal.c)
			{
				od_Mat3 q = od_M3Load(sim->goals.edgeTurn + 9 * k);
				dbar = od_Scale(-1.0, od_V3Load(sim->goals.edgeRest + 6 * k));
				turned = od_M3MulNT(&ri, &q);
			}
			else
			{
				dbar = od_Sub(od_V3Load(g->centers + 3 * j), ci);
			}
			od_Vec3 r = od_Sub(od_M3MulV(&ri, dbar), od_Sub(od_V3Load(s->x + 3 * j), xi));
			double w = od_ElasticScale(sim, j) * od_LinkWeight(sim, k); // s_j w_ij
			e += w * (od_MomentNorm(&turned, &rj, &aj) + g->volumes[j] * od_Dot(r, r));
		}
	}
	return 0.5 * sim->def.stiffness * e;
}

static double od_InertiaEnergy(const od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	const od_State* s = &sim->state;
	double rho = sim->def.density, e = 0.0;
	for (int i = 0; i < g->n; ++i)
	{
		od_Mat3 ri = od_M3Load(s->R + 9 * i), rt = od_M3Load(sim->Rtilde + 9 * i), ai = od_M3Load(g->moments + 9 * i);
		od_Vec3 d = od_Sub(od_V3Load(s->x + 3 * i), od_V3Load(sim->y + 3 * i));
		e += rho * od_MomentNorm(&ri, &rt, &ai) + rho * g->volumes[i] * od_Dot(d, d);
	}
	return e / (2.0 * sim->def.dt * sim->def.dt);
}

static double od_GravityEnergy(const od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	od_Vec3 grav = od_V3Load(sim->def.gravity);
	double e = 0.0;
	for (int i = 0; i < g->n; ++i)
	{
		e -= sim->def.density * g->volumes[i] * od_Dot(grav, od_V3Load(sim->state.x + 3 * i));
	}
	return e;
}

// The potential of the contact forces held during a step's iterations (body_contact.c, surface_contact.c):
// -Σ f_i·x_i.
static double od_ContactEnergy(const od_Sim* sim)
{
	double e = 0.0;
	for (int k = 0; sim->contactForce && k < 3 * sim->graph->n; ++k)
	{
		e -= sim->contactForce[k] * sim->state.x[k];
	}
	for (int k = 0; sim->surface.force && k < 3 * sim->graph->n; ++k)
	{
		e -= sim->surface.force[k] * sim->state.x[k];
	}
	return e;
}

double od_Energy(const od_Sim* sim)
{
	double e = od_ElasticEnergy(sim) + od_Constraints_Energy(sim) + od_Goals_Energy(sim);
	return e + (sim->mode == OD_DYNAMIC ? od_InertiaEnergy(sim) + od_ContactEnergy(sim) : od_GravityEnergy(sim));
}

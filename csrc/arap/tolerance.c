// The on-the-fly error estimate that stops a step's iteration under a tolerance (od_SolverDef.tolerance).
//
// The estimate is the residual of the iteration: r_k = max_i sqrt(|x_i^k - x_i^(k-1)|² + tr(ΔR_i Ā_i ΔR_iᵀ) / v_i)
// / size, the largest RMS displacement of a particle's material (its centre and, through its moment, the turn
// of its ellipsoid) in the last local/global pair, as a fraction of the body's largest extent. A rotation
// about a bar's axis moves no centre; the moment term is what sees the twist of Fig. 2. With an accelerator
// the pair is from one accepted iterate to the next.
// Measured (docs/settings.md): the a-posteriori bound of a contraction, r_k q / (1 - q) with q = r_k / r_(k-1),
// was tried first; after an accelerated jump q is small by chance, and it stopped Chebyshev after one pair a
// step on the Fig. 1 bar (2-second clip error 2.2 % of the bar's length, against 0.16 % with the residual
// itself at 2e-5). Cost: one pass over 12 numbers a particle per pair (a few % of a local step).
//
// The start of a step under a tolerance (od_Tolerance_ChooseStart): the previous rotations or those the
// angular velocities predict, whichever has the lower objective after a global solve. Measured on the
// 2-second clips (docs/settings.md): the twisted bar's handle turns steadily, the predicted rotations win
// every step and Chebyshev needs 20 pairs a step instead of 32 (clip cost 0.378 -> 0.179 ms/step, error
// 0.071 -> 0.134 % of the bar's length); on the sagging bar, which swings, the predicted start put the
// iterate 2.6x further from the solution, and the energy keeps the previous rotations there (0.158 % and
// 0.070 ms before, 0.155 % and 0.072 ms after). Always predicting cost the sagging bar 3.3x.
// With goals carrying the rest the predicted rotations, which carry the goals' turn, are taken untested: on
// the 1,000-particle character of issue 24 (10 steps a frame) the test kept them so often that the iterations
// a step stayed 2.25 without it, and it cost two global solves and two objectives (1.73 -> 1.02 ms a step).
//
// The auto accelerator (od_Tolerance_Plan, od_Tolerance_Check): each step's first two pairs are plain, and
// q = r_2 / r_1 says how they contract. Fast (q < OD_AUTO_SLOW): plain pairs for the rest of the step. Slow:
// Chebyshev, its history seeded with the two plain pairs (as if they had been its first, so the next iterate
// is already extrapolated). A plain pair's estimate is its residual over OD_AUTO_SHARE (doubled): a plain
// residual understates the error where the iteration slows down; Chebyshev's is its residual. Measured on the
// 2-second clips (docs/settings.md, interleaved processor time, medians):
// - the split: the twisted bar's probes contract at q = 0.5 (the twist, seen by the moment term, goes first),
//   the sagging bar's at 0.84-0.89 (its swing); at 0.7 the twisted bar runs plain (4 of 1,074 pairs
//   accelerated), the sagging bar Chebyshev. Deciding by the start instead (plain where the predicted
//   rotations won) failed: they win on 102 of 120 sagging-bar steps too, and plain pairs put its clip at 0.46 %.
// - the doubled plain residual: twisted bar 0.173 % at 1.0x plain 10 (its raw residual at 2e-5: 0.23 %);
//   at a slow probe the raw r_2 stopped 1 sagging-bar step in 5 after two pairs (clip 0.23 %) and the
//   contraction-corrected r_2 q / (1 - q) cost 1,026 pairs against 856; doubled, the sagging bar's clip stays at
//   0.09-0.13 % for tolerances from 1.5e-5 to 3e-5 (the "chebyshev" variant: 0.155-0.29 %).
// - the seed: without it Chebyshev's first pair after the probe is plain again (sagging bar 0.156 %, same cost).
// - the stall (stop 41): plain pairs after a fast probe that have not met the tolerance in OD_AUTO_PLAIN_PAIRS
//   turn Chebyshev on, seeded as after a slow probe. gob at 1,000 particles and 1,000 MPa (docs/goals.md,
//   "Robustness sweep") probed fast at its landing, then stalled plain on its loose buttons: 6 of 10 steps at
//   the 100-pair cap, the buttons thrown 0.85 m (833 pairs; 0.022 m and 356 pairs with the switch). The bars'
//   clips at 2e-5 are unchanged (twisted 0.173 %, 8.9 -> 9.0 pairs); at 1e-5 the twisted bar 0.207 -> 0.173 %,
//   18.4 -> 23.6 pairs.
// Rejected: switching to Chebyshev wherever a plain pair turns slow (twisted bar 4.0x plain 10: Chebyshev
// overshoots from a nearly converged iterate), keeping Chebyshev for the next steps after a slow probe (clip
// 0.13-0.29 % as the re-probe period went 2-10, no steady saving), stopping at the first pair (no saving).
#include "tolerance.h"

#include "core.h"
#include "energy.h"
#include "global_solve.h"
#include "goal.h"
#include "math3.h"
#include "polar.h"

#include <math.h>
#include <string.h>

#define OD_AUTO_SLOW 0.7  // a probe contracting at this rate or slower turns Chebyshev on
#define OD_AUTO_SHARE 0.5 // auto's plain pairs stop at this share of the tolerance (their estimate: r / share)
#define OD_AUTO_PLAIN_PAIRS 30 // plain pairs after a fast probe that have not met the tolerance turn Chebyshev on

static double od_BodySize(const od_Graph* g)
{
	double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY }, size = 0.0;
	for (int i = 0; i < g->n; ++i)
	{
		const double* r = g->radii + 3 * i;
		double reach = fmax(r[0], fmax(r[1], r[2]));
		for (int a = 0; a < 3; ++a)
		{
			lo[a] = fmin(lo[a], g->centers[3 * i + a] - reach);
			hi[a] = fmax(hi[a], g->centers[3 * i + a] + reach);
		}
	}
	for (int a = 0; a < 3; ++a)
	{
		size = fmax(size, hi[a] - lo[a]);
	}
	return size;
}

od_Status od_Tolerance_Prepare(od_Sim* sim)
{
	od_Tolerance* tol = &sim->tolerance;
	if (tol->x)
	{
		return OD_OK;
	}
	int n = sim->graph->n;
	tol->x = od_Alloc(sizeof(double) * 3 * n);
	tol->R = od_Alloc(sizeof(double) * 9 * n);
	if (!tol->x || !tol->R)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the error estimate of %d particles", n);
	}
	tol->size = od_BodySize(sim->graph);
	return OD_OK;
}

void od_Tolerance_Destroy(od_Tolerance* tol)
{
	od_Free(tol->x);
	od_Free(tol->R);
	memset(tol, 0, sizeof *tol);
}

// The rotations the angular velocities predict, made proper rotations, as the state's.
static void od_PredictedRotations(od_Sim* sim)
{
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Mat3 r = od_M3Load(sim->Rtilde + 9 * i);
		od_Orthonormalize(&r);
		od_M3Store(sim->state.R + 9 * i, &r);
	}
}

void od_Tolerance_ChooseStart(od_Sim* sim)
{
	int n = sim->graph->n;
	if (od_Goals_CarryRest(sim))
	{
		od_PredictedRotations(sim); // untested: see the note above
		return;
	}
	if (od_GlobalStep(sim) != OD_OK)
	{
		return; // the iteration's own global solve reports it
	}
	double kept = od_Energy(sim);
	od_PredictedRotations(sim);
	if (od_GlobalStep(sim) != OD_OK || !(od_Energy(sim) < kept))
	{
		memcpy(sim->state.R, sim->previous.R, sizeof(double) * 9 * n);
	}
}

void od_Tolerance_Start(od_Sim* sim)
{
	od_Tolerance* tol = &sim->tolerance;
	memcpy(tol->x, sim->state.x, sizeof(double) * 3 * sim->graph->n);
	memcpy(tol->R, sim->state.R, sizeof(double) * 9 * sim->graph->n);
}

// The largest squared RMS displacement of a particle's material between the remembered iterate and this one.
static double od_LargestMove2(od_Sim* sim)
{
	const od_Graph* g = sim->graph;
	od_Tolerance* tol = &sim->tolerance;
	double largest = 0.0;
	for (int i = 0; i < g->n; ++i)
	{
		od_Vec3 dx = od_Sub(od_V3Load(sim->state.x + 3 * i), od_V3Load(tol->x + 3 * i));
		od_Mat3 dr = od_M3Load(sim->state.R + 9 * i), before = od_M3Load(tol->R + 9 * i);
		od_M3AddScaled(&dr, -1.0, &before);
		od_Mat3 moment = od_M3Load(g->moments + 9 * i);
		od_Mat3 da = od_M3Mul(&dr, &moment);
		largest = fmax(largest, od_Dot(dx, dx) + od_M3Inner(&da, &dr) / g->volumes[i]);
	}
	return largest;
}

od_StepPlan od_Tolerance_Plan(const od_Sim* sim)
{
	od_AcceleratorKind kind = sim->solverDef.accelerator;
	bool dynamic = sim->mode == OD_DYNAMIC;
	double tolerance = dynamic && sim->solverDef.tolerance > 0.0 ? sim->solverDef.tolerance : 0.0;
	bool probing = kind == OD_ACCELERATE_AUTO && tolerance > 0.0;
	bool accelerate = kind != OD_ACCELERATE_NONE && !probing; // auto at a fixed count: Chebyshev
	return (od_StepPlan){ .accelerate = accelerate, .probing = probing, .tolerance = tolerance, .last = -1.0 };
}

void od_Tolerance_PlainPlan(od_StepPlan* plan)
{
	plan->accelerate = plan->probing = false;
	plan->plain = plan->tolerance > 0.0;
	plan->plainLeft = 0;
}

// The probe's second residual decides the rest of the step (the design note above).
static double od_Probe(od_Sim* sim, od_StepPlan* plan, double residual)
{
	plan->probing = false;
	if (!(residual < OD_AUTO_SLOW * plan->last))
	{
		plan->accelerate = true;
		od_Accelerator_Continue(&sim->accelerator, sim->tolerance.R);
	}
	else
	{
		plan->plain = true;
		plan->plainLeft = OD_AUTO_PLAIN_PAIRS;
	}
	return residual / OD_AUTO_SHARE; // both: the estimate of the probe's last plain pair
}

// Auto's plain pairs that have not met the tolerance in OD_AUTO_PLAIN_PAIRS turn Chebyshev on, seeded as after a
// slow probe (the design note above).
static void od_PlainStalled(od_Sim* sim, od_StepPlan* plan)
{
	if (plan->plainLeft > 0 && --plan->plainLeft == 0)
	{
		plan->plain = false;
		plan->accelerate = true;
		od_Accelerator_Continue(&sim->accelerator, sim->tolerance.R);
	}
}

double od_Tolerance_Check(od_Sim* sim, od_StepPlan* plan)
{
	od_Tolerance* tol = &sim->tolerance;
	double residual = sqrt(od_LargestMove2(sim)) / tol->size, estimate = residual;
	if (plan->probing && residual > 0.0)
	{
		estimate = plan->last < 0.0 ? INFINITY : od_Probe(sim, plan, residual); // one residual: no rate yet
		plan->last = residual;
	}
	else if (plan->plain)
	{
		estimate = residual / OD_AUTO_SHARE;
		if (estimate > plan->tolerance)
		{
			od_PlainStalled(sim, plan);
		}
	}
	od_Tolerance_Start(sim);
	return estimate;
}

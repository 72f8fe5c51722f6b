// libFuzzer target: a byte-driven sequence of od_Sim_* calls on a small graph (a chain, two separate
// chains, or a lattice with diagonals, with random rest frames): add and remove position and direction
// constraints, move targets, change weights, set and clear the floor, step, solve statically, set the
// state, change parameters, read the energy and its trace.
// Invariants after every call: a failed call changes nothing (state bit for bit, constraint count,
// parameters); a successful step or static solve leaves a finite state; the constraint set agrees with the
// ids the harness has seen added and removed; unknown ids give OD_ERROR_NOT_FOUND; counters never fall.
#include "fuzz_input.h"

#include "opdeform/opdeform.h"

#include <stdlib.h>

#define MAX_N 24
#define MAX_IDS 64
#define MAX_OPS 48

typedef struct Snapshot
{
	double x[3 * MAX_N], R[9 * MAX_N], v[3 * MAX_N], w[3 * MAX_N];
	int constraints;
	od_SimDef def;
	od_SimCounters counters;
} Snapshot;

static void take(const od_Sim* sim, int n, Snapshot* s)
{
	memcpy(s->x, od_Sim_GetPositions(sim), sizeof(double) * 3 * n);
	memcpy(s->R, od_Sim_GetRotations(sim), sizeof(double) * 9 * n);
	memcpy(s->v, od_Sim_GetVelocities(sim), sizeof(double) * 3 * n);
	memcpy(s->w, od_Sim_GetAngularVelocities(sim), sizeof(double) * 3 * n);
	s->constraints = od_Sim_GetConstraintCount(sim);
	s->def = od_Sim_GetDef(sim);
	s->counters = od_Sim_GetCounters(sim);
}

static int same_state(const od_Sim* sim, int n, const Snapshot* s)
{
	return memcmp(s->x, od_Sim_GetPositions(sim), sizeof(double) * 3 * n) == 0 &&
		   memcmp(s->R, od_Sim_GetRotations(sim), sizeof(double) * 9 * n) == 0 &&
		   memcmp(s->v, od_Sim_GetVelocities(sim), sizeof(double) * 3 * n) == 0 &&
		   memcmp(s->w, od_Sim_GetAngularVelocities(sim), sizeof(double) * 3 * n) == 0;
}

static int finite_state(const od_Sim* sim, int n)
{
	return fuzz_all_finite(od_Sim_GetPositions(sim), (size_t)3 * n) &&
		   fuzz_all_finite(od_Sim_GetRotations(sim), (size_t)9 * n) &&
		   fuzz_all_finite(od_Sim_GetVelocities(sim), (size_t)3 * n) &&
		   fuzz_all_finite(od_Sim_GetAngularVelocities(sim), (size_t)3 * n);
}

// A small graph: 0 chain, 1 two separate chains, 2 a 3x2x2 lattice with face diagonals.
static od_Graph* make_graph(FuzzInput* in)
{
	int shape = fuzz_int(in, 0, 2);
	int len = fuzz_int(in, 1, 10);
	double spacing = 0.05 + 0.01 * fuzz_int(in, 0, 20);
	double centers[3 * MAX_N], radii[3 * MAX_N], axes[9 * MAX_N];
	int edges[2 * 4 * MAX_N];
	int n = 0, m = 0;
	if (shape == 2)
	{
		int id[3][2][2];
		for (int a = 0; a < 3; ++a)
			for (int b = 0; b < 2; ++b)
				for (int c = 0; c < 2; ++c)
				{
					id[a][b][c] = n;
					double p[3] = { a * spacing, b * spacing, c * spacing };
					memcpy(centers + 3 * n++, p, sizeof p);
				}
		for (int a = 0; a < 3; ++a)
			for (int b = 0; b < 2; ++b)
				for (int c = 0; c < 2; ++c)
				{
					int nb[4][3] = { { a + 1, b, c }, { a, b + 1, c }, { a, b, c + 1 }, { a + 1, b + 1, c } };
					for (int k = 0; k < 4; ++k)
					{
						if (nb[k][0] < 3 && nb[k][1] < 2 && nb[k][2] < 2)
						{
							edges[2 * m] = id[a][b][c];
							edges[2 * m++ + 1] = id[nb[k][0]][nb[k][1]][nb[k][2]];
						}
					}
				}
	}
	else
	{
		for (int chain = 0; chain <= shape; ++chain)
		{
			for (int i = 0; i < len; ++i)
			{
				double p[3] = { i * spacing, chain * 4.0 * spacing, 0.0 };
				memcpy(centers + 3 * n, p, sizeof p);
				if (i > 0)
				{
					edges[2 * m] = n - 1;
					edges[2 * m++ + 1] = n;
				}
				++n;
			}
		}
	}
	int frames = fuzz_byte(in) & 1;
	for (int i = 0; i < n; ++i)
	{
		for (int k = 0; k < 3; ++k)
		{
			radii[3 * i + k] = spacing * (0.3 + 0.1 * fuzz_int(in, 0, 7));
		}
		if (frames)
		{
			fuzz_rotation(in, axes + 9 * i);
		}
	}
	od_GraphDef def = od_DefaultGraphDef();
	def.particleCount = n;
	def.centers = centers;
	def.radii = radii;
	def.axes = frames ? axes : NULL;
	def.edgeCount = m;
	def.edges = edges;
	od_Graph* g = NULL;
	CHECK(od_Graph_Create(&def, &g) == OD_OK);
	return g;
}

static od_SimDef fuzz_def(FuzzInput* in)
{
	od_SimDef def = od_DefaultSimDef();
	def.stiffness = fuzz_positive(in, 1e5);
	def.density = fuzz_positive(in, 1e3);
	def.dt = fuzz_positive(in, 1.0 / 60.0);
	def.iterations = fuzz_int(in, -1, 8);
	fuzz_vec3(in, 10.0, def.gravity);
	def.damping = fuzz_double(in, 0.25);
	def.skinNeighbors = fuzz_int(in, -1, 18);
	return def;
}

static double fuzz_weight(FuzzInput* in, int direction)
{
	return fuzz_positive(in, direction ? 1e2 : 1e5);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
	FuzzInput in = { data, size };
	od_Graph* g = make_graph(&in);
	int n = od_Graph_GetParticleCount(g);
	od_SimDef def = fuzz_def(&in);
	od_Sim* sim = NULL;
	if (od_Sim_Create(g, &def, &sim) != OD_OK)
	{
		CHECK(sim == NULL);
		def = od_DefaultSimDef();
		CHECK(od_Sim_Create(g, &def, &sim) == OD_OK);
	}
	int live[MAX_IDS];
	int liveCount = 0, nextId = 0;
	static Snapshot before;

	for (int op = 0; op < MAX_OPS && in.size > 0; ++op)
	{
		take(sim, n, &before);
		int code = fuzz_int(&in, 0, 13);
		od_Status status = OD_OK;
		int changesState = 0; // a successful call of this kind may change the state
		switch (code)
		{
			case 0:
			case 1:
			{
				double p[3], d[3], t[3];
				fuzz_vec3(&in, 0.5, p);
				if (code == 1)
				{
					fuzz_vec3(&in, 1.0, d);
				}
				int withTarget = fuzz_byte(&in) & 1;
				if (withTarget)
				{
					fuzz_vec3(&in, 0.5, t);
				}
				double w = fuzz_weight(&in, code);
				int id = -7;
				status = code == 0 ? od_Sim_AddPositionConstraint(sim, p, withTarget ? t : NULL, w, &id)
								   : od_Sim_AddDirectionConstraint(sim, p, d, withTarget ? t : NULL, w, &id);
				CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT);
				if (status == OD_OK)
				{
					CHECK(id == nextId);
					CHECK(od_Sim_GetConstraintCount(sim) == before.constraints + 1);
					nextId++;
					live[liveCount++] = id; // MAX_OPS < MAX_IDS: every id fits
				}
				break;
			}
			case 2:
			case 3:
			case 4:
			{
				int pick = fuzz_int(&in, 0, 255);
				int id = liveCount > 0 && pick < 192 ? live[pick % liveCount] : fuzz_int(&in, -2, nextId + 1);
				int known = 0;
				for (int k = 0; k < liveCount; ++k)
				{
					known |= live[k] == id;
				}
				if (code == 2)
				{
					double t[3];
					fuzz_vec3(&in, 0.5, t);
					status = od_Sim_SetConstraintTarget(sim, id, t);
				}
				else if (code == 3)
				{
					status = od_Sim_SetConstraintWeight(sim, id, fuzz_weight(&in, 0));
				}
				else
				{
					status = od_Sim_RemoveConstraint(sim, id);
				}
				CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT || status == OD_ERROR_NOT_FOUND);
				CHECK(known ? status != OD_ERROR_NOT_FOUND : status != OD_OK);
				if (status == OD_OK && code == 4)
				{
					for (int k = 0; k < liveCount; ++k)
					{
						if (live[k] == id)
						{
							live[k] = live[--liveCount];
							break;
						}
					}
					CHECK(od_Sim_GetConstraintCount(sim) == before.constraints - 1);
				}
				break;
			}
			case 5:
				status = od_Sim_SetFloor(sim, fuzz_double(&in, 0.5), fuzz_double(&in, 0.5));
				CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT);
				break;
			case 6:
				od_Sim_ClearFloor(sim);
				break;
			case 7:
			case 8:
			{
				int count = code == 7 ? fuzz_int(&in, -1, 3) : fuzz_int(&in, -1, 8);
				status = code == 7 ? od_Sim_Step(sim, count) : od_Sim_SolveStatic(sim, count);
				CHECK(status != OD_ERROR_NOT_FOUND && status != OD_ERROR_BUSY);
				changesState = 1;
				if (status == OD_OK)
				{
					CHECK(finite_state(sim, n));
				}
				break;
			}
			case 9:
			{
				static double x[3 * MAX_N], r[9 * MAX_N], v[3 * MAX_N], w[3 * MAX_N];
				int mode = fuzz_byte(&in);
				for (int i = 0; i < n; ++i)
				{
					double dx[3];
					fuzz_vec3(&in, 0.05, dx);
					for (int k = 0; k < 3; ++k)
					{
						x[3 * i + k] = before.x[3 * i + k] + dx[k];
					}
					fuzz_frame(&in, r + 9 * i);
				}
				for (int k = 0; k < 3 * n; ++k)
				{
					v[k] = (mode & 1) ? fuzz_double(&in, 1.0) : 0.0;
					w[k] = (mode & 2) ? fuzz_double(&in, 1.0) : 0.0;
				}
				status = od_Sim_SetState(sim, (mode & 4) ? NULL : x, r, (mode & 1) ? v : NULL, (mode & 2) ? w : NULL);
				CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT);
				changesState = 1;
				if (status == OD_OK)
				{
					CHECK(memcmp(od_Sim_GetPositions(sim), x, sizeof(double) * 3 * n) == 0);
					CHECK(finite_state(sim, n));
				}
				break;
			}
			case 10:
			{
				od_SimDef d = fuzz_def(&in);
				status = od_Sim_SetDef(sim, &d);
				CHECK(status == OD_OK || status == OD_ERROR_ARGUMENT);
				if (status == OD_OK)
				{
					od_SimDef got = od_Sim_GetDef(sim);
					CHECK(memcmp(&got, &d, sizeof d) == 0);
				}
				else
				{
					od_SimDef got = od_Sim_GetDef(sim);
					CHECK(memcmp(&got, &before.def, sizeof got) == 0);
				}
				break;
			}
			case 11:
				(void)od_Sim_GetEnergy(sim);
				break;
			case 12:
			{
				od_Sim_SetEnergyTrace(sim, fuzz_byte(&in) & 1);
				int count = -1;
				const double* trace = od_Sim_GetEnergyTrace(sim, &count);
				CHECK(count == 0 || trace != NULL);
				break;
			}
			default:
			{
				int idx[16];
				double w[16];
				double p[3];
				fuzz_vec3(&in, 0.5, p);
				int count = od_Graph_SkinWeights(g, p, fuzz_int(&in, 1, 16), idx, w);
				CHECK(count >= 1 && count <= n);
				break;
			}
		}
		TRACE("op %d -> %s %s\n", code, od_StatusName(status), status ? od_GetErrorMessage() : "");
		if (status != OD_OK || !changesState)
		{
			CHECK(same_state(sim, n, &before));
		}
		if (status != OD_OK)
		{
			CHECK(od_Sim_GetConstraintCount(sim) == before.constraints);
		}
		CHECK(od_Sim_GetConstraintCount(sim) == liveCount);
		od_SimCounters c = od_Sim_GetCounters(sim);
		CHECK(c.steps >= before.counters.steps && c.factorizations >= before.counters.factorizations &&
			  c.solves >= before.counters.solves);
	}
	od_Sim_Destroy(sim);
	od_Graph_Destroy(g);
	return 0;
}

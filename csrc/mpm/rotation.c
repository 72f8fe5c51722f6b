// Particle rotation from the polar decomposition of the deformation gradient (Song et al. 2022).
//
// Design: a particle's material rotation is R = U Vᵀ of F's SVD (od_PolarRotation's product; the SVDs of a
// batch of particles computed together by od_Svd3Many). Its orientation is advanced from one update (a frame)
// to the next by the increment ΔR = R_new R_oldᵀ with the angle scaled by η in axis-angle form — the seed's
// spin exaggeration without an Euler axis order:
//     Q ← exp(η log ΔR) Q,    Q₀ = the rest orientation.
// With η = 1 this is exactly R applied to the rest orientation; with η = 0 the particle keeps its rest
// orientation (plain MLS-MPM, the seed's Fig. 9 comparison). Working with increments keeps the output
// continuous however far a particle has turned (no wrap at π when η ≠ 1), and since each increment's
// quaternion is taken in the hemisphere of the previous one, the output quaternions never flip sign
// between frames (what interpolating renderers need). Increments must stay below half a turn per update.
// The update runs in batches of OD_ROTATION_BATCH particles with an interrupt check between them, writing
// into the reorder buffer, copied over the quaternions only when all are done: a stopped update changes
// nothing.
#include "world.h"

#include "interrupt.h"
#include "polar.h"

#include <string.h>

void od_QuatFromMatrix(const od_Mat3* r, double q[4])
{
	const double* m = r->m;
	double tr = m[0] + m[4] + m[8];
	if (tr > 0.0)
	{
		double s = 2.0 * sqrt(tr + 1.0);
		q[0] = 0.25 * s;
		q[1] = (m[7] - m[5]) / s;
		q[2] = (m[2] - m[6]) / s;
		q[3] = (m[3] - m[1]) / s;
	}
	else if (m[0] > m[4] && m[0] > m[8])
	{
		double s = 2.0 * sqrt(1.0 + m[0] - m[4] - m[8]);
		q[0] = (m[7] - m[5]) / s;
		q[1] = 0.25 * s;
		q[2] = (m[1] + m[3]) / s;
		q[3] = (m[2] + m[6]) / s;
	}
	else if (m[4] > m[8])
	{
		double s = 2.0 * sqrt(1.0 + m[4] - m[0] - m[8]);
		q[0] = (m[2] - m[6]) / s;
		q[1] = (m[1] + m[3]) / s;
		q[2] = 0.25 * s;
		q[3] = (m[5] + m[7]) / s;
	}
	else
	{
		double s = 2.0 * sqrt(1.0 + m[8] - m[0] - m[4]);
		q[0] = (m[3] - m[1]) / s;
		q[1] = (m[2] + m[6]) / s;
		q[2] = (m[5] + m[7]) / s;
		q[3] = 0.25 * s;
	}
}

od_Mat3 od_QuatToMatrix(const double q[4])
{
	double w = q[0], x = q[1], y = q[2], z = q[3];
	return (od_Mat3){ { 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y), 2 * (x * y + w * z),
						1 - 2 * (x * x + z * z), 2 * (y * z - w * x), 2 * (x * z - w * y), 2 * (y * z + w * x),
						1 - 2 * (x * x + y * y) } };
}

// a ⊗ b
static void od_QuatMul(const double a[4], const double b[4], double out[4])
{
	double r[4] = { a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
					a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
					a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
					a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0] };
	double n = 1.0 / sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
	for (int k = 0; k < 4; ++k)
	{
		out[k] = n * r[k];
	}
}

// The increment's angle scaled by eta: q = (cos θ/2, sin θ/2 a) -> (cos ηθ/2, sin ηθ/2 a), for w >= 0.
static void od_QuatScaleAngle(const double q[4], double eta, double out[4])
{
	double s = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
	double half = eta * atan2(s, q[0]);
	double f = s > 1e-300 ? sin(half) / s : eta;
	out[0] = cos(half);
	for (int k = 1; k < 4; ++k)
	{
		out[k] = f * q[k];
	}
}

#define OD_ROTATION_TASKS 256 // per batch
#define OD_ROTATION_BATCH 65536 // particles between interrupt checks (about 26 ms on one thread)
#define OD_ROTATION_NS 400.0 // a particle on one thread: the pool's measure of the work (docs/speed.md)

// A batch of the update: particles[begin, begin + count) write their new quaternions by id into quat and
// polarQuat (the reorder buffer), so that a call stopped between batches leaves the world's as they were.
typedef struct od_RotationJob
{
	const od_MpmWorld* w;
	int begin, count;
	double *quat, *polarQuat;
} od_RotationJob;

// F scaled where FᵀF would over- or underflow: R ignores a positive scale.
static od_Mat3 od_RotationInput(const od_MpmParticle* p)
{
	od_Mat3 F = od_M3Load(p->F);
	double size = 0.0;
	for (int k = 0; k < 9; ++k)
	{
		size = fmax(size, fabs(F.m[k]));
	}
	if (size > 1e100 || (size > 0.0 && size < 1e-100))
	{
		for (int k = 0; k < 9; ++k)
		{
			F.m[k] /= size;
		}
	}
	return F;
}

// The particle's new orientation from R = U Vᵀ (od_PolarRotation's product), by id into the job's arrays.
static void od_RotationWrite(const od_RotationJob* job, const od_MpmParticle* p, const od_Mat3* U, const od_Mat3* V)
{
	const od_MpmWorld* w = job->w;
	od_Mat3 R = od_M3MulNT(U, V);
	const double* old = w->state.polarQuat + 4 * p->id;
	const double* q = w->state.quat + 4 * p->id;
	double now[4], inverse[4] = { old[0], -old[1], -old[2], -old[3] }, delta[4], scaled[4];
	od_QuatFromMatrix(&R, now);
	if (now[0] * old[0] + now[1] * old[1] + now[2] * old[2] + now[3] * old[3] < 0.0)
	{
		for (int k = 0; k < 4; ++k)
		{
			now[k] = -now[k];
		}
	}
	od_QuatMul(now, inverse, delta);
	od_QuatScaleAngle(delta, w->model.def.spin, scaled);
	od_QuatMul(scaled, q, job->quat + 4 * p->id);
	memcpy(job->polarQuat + 4 * p->id, now, sizeof now);
}

// The task's particles OD_MPM_SVD_BATCH at a time: their SVDs together (od_Svd3Many), then each orientation.
static void od_RotationTask(void* ctx, int task, int thread)
{
	const od_RotationJob* job = ctx;
	const od_MpmParticle* particles = job->w->state.particles;
	od_MpmSvdBatch* batch = &job->w->threadData[thread].svd;
	int begin, end;
	od_TaskRange(job->count, OD_ROTATION_TASKS, task, &begin, &end);
	for (int first = job->begin + begin; first < job->begin + end; first += OD_MPM_SVD_BATCH)
	{
		int count = job->begin + end - first < OD_MPM_SVD_BATCH ? job->begin + end - first : OD_MPM_SVD_BATCH;
		for (int b = 0; b < count; ++b)
		{
			batch->F[b] = od_RotationInput(&particles[first + b]);
		}
		od_Svd3Many(count, batch->F, batch->U, batch->s, batch->V);
		for (int b = 0; b < count; ++b)
		{
			od_RotationWrite(job, &particles[first + b], &batch->U[b], &batch->V[b]);
		}
	}
}

_Static_assert(sizeof(od_MpmParticle) >= 8 * sizeof(double), "the reorder buffer holds both new quaternions");

od_Status od_MpmWorld_UpdateOrientations(od_MpmWorld* w)
{
	size_t n = (size_t)w->state.count;
	if (n == 0)
	{
		return OD_OK;
	}
	double* next = (double*)w->spare; // free between substeps
	od_RotationJob job = { .w = w, .quat = next, .polarQuat = next + 4 * n };
	for (job.begin = 0; job.begin < w->state.count; job.begin += OD_ROTATION_BATCH)
	{
		od_Status status = od_CheckInterrupt();
		if (status != OD_OK)
		{
			return status;
		}
		job.count = w->state.count - job.begin < OD_ROTATION_BATCH ? w->state.count - job.begin : OD_ROTATION_BATCH;
		od_Pool_Run(w->pool, OD_ROTATION_TASKS, OD_ROTATION_NS * job.count, od_RotationTask, &job);
	}
	memcpy(w->state.quat, job.quat, 4 * sizeof(double) * n);
	memcpy(w->state.polarQuat, job.polarQuat, 4 * sizeof(double) * n);
	return OD_OK;
}

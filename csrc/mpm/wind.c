// Wind on the MPM grid: 2-D Perlin noise over the horizontal plane, several octaves, scaled by height and
// drifting over time (the seed's Fig. 8).
//
// Design: a flake only tumbles where the flow has vorticity (the material's spin is half the curl of its
// velocity), so the wind has two forms: NOISE, two independent noise channels as the x and y velocity
// (a vortical flow; the height profile adds shear), and POTENTIAL, the horizontal gradient of one noise
// channel with no height profile (curl-free: the control case). Grid velocities relax towards the wind at
// the drag rate (world.c), so the wind cannot push faster than itself.
// The potential is the control only if it matches the noise wind's speed and the grid resolves it. Its
// octave o is weighted like the noise wind's velocity octave (persistence^o on the gradient in lattice
// units, not on the potential: a gradient weighted by the potential's amplitude grows as 2^o with the
// frequency, and in the README's flake scene its finest octave made it 1.75x faster than the noise wind and
// turned flakes a median 16.3 degrees in 0.5 s against 7.5 in the noise wind), scaled by
// od_potentialGain so that the mean speeds agree, and it drops the octaves shorter than
// od_resolvedCells grid cells (measured in docs/mpm.md). Even so it turns the README's flakes a tenth as much
// as NOISE, not zero (the flakes' pressure and the grid's mixing of their velocities; keeping only octaves of
// 16 cells or more gives 4.5-6.9 %: docs/mpm.md, "The step and the wind control"); a uniform wind turns none.
#include "world.h"

#include "core.h"

static const double od_windChannelOffset = 71.37; // decorrelates the y channel from the x channel
// Mean |(noise, noise')| / mean |∇noise| of 2-D Perlin noise (400,000 samples): 0.282 / 0.826.
static const double od_potentialGain = 0.341;
static const double od_resolvedCells = 8.0; // the shortest wavelength of a potential octave, in cells

od_MpmWindDef od_DefaultMpmWindDef(void)
{
	return (od_MpmWindDef){ .kind = OD_MPM_WIND_OFF,
							.amplitude = 1.0,
							.wavelength = 4.0,
							.octaves = 4,
							.persistence = 0.5,
							.drag = 2.0,
							.refHeight = 1.0,
							.seed = 1 };
}

// The potential's octaves and gain: those at least od_resolvedCells cells long, scaled so that the RMS speed
// of their normalised sum is that of the noise wind's sum over all its octaves (independent octaves: the RMS
// of sum a_o n_o / sum a_o is rms(n) sqrt(sum a_o²) / sum a_o).
static void od_MpmWind_Resolve(od_MpmWind* wind, double dx)
{
	const od_MpmWindDef* d = &wind->def;
	wind->octaves = d->octaves;
	wind->gain = 1.0;
	if (d->kind != OD_MPM_WIND_POTENTIAL)
	{
		return;
	}
	double finest = d->wavelength / (od_resolvedCells * dx); // the octaves that fit: 2^o <= finest
	wind->octaves = (int)fmax(1.0, fmin(d->octaves, 1.0 + floor(log2(finest))));
	double amp = 1.0, sum[2] = { 0.0, 0.0 }, squares[2] = { 0.0, 0.0 }; // [0]: all octaves, [1]: kept
	for (int o = 0; o < d->octaves; ++o, amp *= d->persistence)
	{
		for (int kept = 0; kept < 1 + (o < wind->octaves); ++kept)
		{
			sum[kept] += amp;
			squares[kept] += amp * amp;
		}
	}
	wind->gain = od_potentialGain * sqrt(squares[0] / squares[1]) * sum[1] / sum[0];
}

od_Status od_MpmWind_Set(od_MpmWind* wind, const od_MpmWindDef* def, double dx)
{
	if (def->kind != OD_MPM_WIND_OFF && def->kind != OD_MPM_WIND_NOISE && def->kind != OD_MPM_WIND_POTENTIAL)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "wind: unknown kind %d", (int)def->kind);
	}
	if (!(def->wavelength > 0.0) || !(def->refHeight > 0.0) || !(def->drag >= 0.0) || def->octaves < 1 ||
		def->octaves > 16 || !(def->persistence > 0.0) || !isfinite(def->amplitude) || !isfinite(def->exponent) ||
		!od_IsFinite3(def->velocity) || !isfinite(def->drift[0]) || !isfinite(def->drift[1]) ||
		!isfinite(def->ground) || !isfinite(def->persistence) || !isfinite(def->drag))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "wind: need wavelength > 0, ref_height > 0, drag >= 0, octaves in [1, "
										  "16], persistence > 0 and finite values");
	}
	wind->def = *def;
	od_MpmWind_Resolve(wind, dx);
	// Permutation by a seeded Fisher-Yates shuffle (LCG), repeated once for wrap-free indexing.
	uint32_t state = def->seed * 747796405u + 2891336453u;
	for (int i = 0; i < 256; ++i)
	{
		wind->perm[i] = (uint8_t)i;
	}
	for (int i = 255; i > 0; --i)
	{
		state = state * 1664525u + 1013904223u;
		int j = (int)((state >> 8) % (uint32_t)(i + 1));
		uint8_t t = wind->perm[i];
		wind->perm[i] = wind->perm[j];
		wind->perm[j] = t;
	}
	for (int i = 0; i < 256; ++i)
	{
		wind->perm[256 + i] = wind->perm[i];
	}
	return OD_OK;
}

// Gradient of lattice corner (i, j): one of 8 unit directions.
static void od_Gradient(const od_MpmWind* wind, int i, int j, double* gx, double* gy)
{
	static const double dirs[8][2] = { { 1, 0 },		  { -1, 0 },		{ 0, 1 },		  { 0, -1 },
									   { 0.70710678, 0.70710678 },  { -0.70710678, 0.70710678 },
									   { 0.70710678, -0.70710678 }, { -0.70710678, -0.70710678 } };
	int h = wind->perm[wind->perm[i & 255] + (j & 255)] & 7;
	*gx = dirs[h][0];
	*gy = dirs[h][1];
}

// 2-D Perlin noise at (x, y) with its gradient (quintic fade).
static double od_Perlin(const od_MpmWind* wind, double x, double y, double grad[2])
{
	double fx = floor(x), fy = floor(y);
	if (!isfinite(fx) || !isfinite(fy)) // a lattice coordinate that overflowed (a tiny wavelength): no noise
	{
		grad[0] = grad[1] = 0.0;
		return 0.0;
	}
	int i = (int)fmod(fx, 256.0), j = (int)fmod(fy, 256.0); // the lattice repeats every 256 (perm & 255)
	double u = x - fx, v = y - fy;
	double su = u * u * u * (u * (u * 6 - 15) + 10), dsu = 30 * u * u * (u * (u - 2) + 1);
	double sv = v * v * v * (v * (v * 6 - 15) + 10), dsv = 30 * v * v * (v * (v - 2) + 1);
	double n[2][2], gxs[2][2], gys[2][2];
	for (int a = 0; a < 2; ++a)
	{
		for (int b = 0; b < 2; ++b)
		{
			od_Gradient(wind, i + a, j + b, &gxs[a][b], &gys[a][b]);
			n[a][b] = gxs[a][b] * (u - a) + gys[a][b] * (v - b);
		}
	}
	double x0 = n[0][0] + su * (n[1][0] - n[0][0]), x1 = n[0][1] + su * (n[1][1] - n[0][1]);
	double value = x0 + sv * (x1 - x0);
	// d/du and d/dv of the bilinear blend of the corner values
	double dx0 = gxs[0][0] + su * (gxs[1][0] - gxs[0][0]) + dsu * (n[1][0] - n[0][0]);
	double dx1 = gxs[0][1] + su * (gxs[1][1] - gxs[0][1]) + dsu * (n[1][1] - n[0][1]);
	double dy0 = gys[0][0] + su * (gys[1][0] - gys[0][0]);
	double dy1 = gys[0][1] + su * (gys[1][1] - gys[0][1]);
	grad[0] = dx0 + sv * (dx1 - dx0);
	grad[1] = dy0 + sv * (dy1 - dy0) + dsv * (x1 - x0);
	return value;
}

// Octave sum normalised by the sum of amplitudes; grad is each octave's gradient in its own lattice units
// (the gradient of the sum of amp_o noise_o / 2^o, times the first octave's wavelength).
static double od_Fractal(const od_MpmWind* wind, double x, double y, double grad[2])
{
	const od_MpmWindDef* d = &wind->def;
	double freq = 1.0 / d->wavelength, amp = 1.0, total = 0.0, value = 0.0;
	grad[0] = grad[1] = 0.0;
	for (int o = 0; o < wind->octaves; ++o)
	{
		double g[2];
		value += amp * od_Perlin(wind, x * freq + 17.0 * o, y * freq + 31.0 * o, g);
		grad[0] += amp * g[0];
		grad[1] += amp * g[1];
		total += amp;
		amp *= d->persistence;
		freq *= 2.0;
	}
	grad[0] /= total;
	grad[1] /= total;
	return value / total;
}

void od_MpmWind_Column(const od_MpmWind* wind, double x, double y, double time, double column[2])
{
	const od_MpmWindDef* d = &wind->def;
	double px = x - d->drift[0] * time, py = y - d->drift[1] * time, g[2];
	if (d->kind == OD_MPM_WIND_POTENTIAL)
	{
		// the gradient of a velocity potential, so the flow has no curl
		od_Fractal(wind, px, py, g);
		column[0] = d->amplitude * wind->gain * g[0];
		column[1] = d->amplitude * wind->gain * g[1];
		return;
	}
	column[0] = d->amplitude * od_Fractal(wind, px, py, g);
	column[1] = d->amplitude * od_Fractal(wind, px + od_windChannelOffset, py - od_windChannelOffset, g);
}

double od_MpmWind_Height(const od_MpmWind* wind, double z)
{
	const od_MpmWindDef* d = &wind->def;
	if (d->kind != OD_MPM_WIND_NOISE || d->exponent == 0.0)
	{
		return 1.0;
	}
	double height = (z - d->ground) / d->refHeight;
	return height > 0.0 ? pow(height, d->exponent) : 0.0;
}

od_Vec3 od_MpmWind_At(const od_MpmWind* wind, const double column[2], double kappa)
{
	const od_MpmWindDef* d = &wind->def;
	return od_V3(kappa * (d->velocity[0] + column[0]), kappa * (d->velocity[1] + column[1]), kappa * d->velocity[2]);
}

od_Vec3 od_MpmWind_Velocity(const od_MpmWind* wind, od_Vec3 x, double time)
{
	double column[2];
	od_MpmWind_Column(wind, x.x, x.y, time, column);
	return od_MpmWind_At(wind, column, od_MpmWind_Height(wind, x.z));
}

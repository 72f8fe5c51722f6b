// Forward and back substitution with the global matrix's Cholesky factor (the hot half of the global step).
//
// CHOLMOD orders the matrix (AMD, with the elimination tree postordered) and factors it once per change of
// the model; every iteration then substitutes. Here the factor is kept as compressed columns of LLᵀ with
// the diagonal apart (as 1/L_jj) and rows sorted, the three right sides travel interleaved per row so each
// entry of L is read once per substitution, and the permutation is folded into reading b and writing x.
//
// Threads: in postorder the subtree of column j is the column range [j - size_j + 1, j], and two disjoint
// subtrees share no rows but their common ancestors'. The plan cuts the elimination tree into an antichain
// of subtrees, packs them into one bin per thread (largest first) and leaves the columns above them, the
// top, to one thread:
//   forward  L y = b:  each bin runs its columns in order; updates of rows above a subtree go to the bin's
//                      own accumulator, summed into the top rows in bin order afterwards; then the top;
//   backward Lᵀ x = y: the top first, then each bin, reading only its own rows and the top's.
// The order of every sum depends on the plan alone, so a given thread count gives the same bits each run.
#include "cholesky.h"

#include "core.h"
#include "pool.h"

#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

typedef struct od_CholRange
{
	int lo, hi;
} od_CholRange;

struct od_Cholesky
{
	int n;
	int* perm;       // row k of the factor is particle perm[k]
	int* colStart;   // n + 1: the off-diagonal entries of column j
	int* row;        // sorted within a column
	double* val;
	double* invDiag; // 1 / L_jj
	double* y;       // 3n, the right sides in factor order

	// The parallel plan (threads > 1).
	int threads;
	int* binStart;        // threads + 1, into ranges
	od_CholRange* ranges; // subtrees, ascending within a bin
	int* top;             // the columns in no subtree, ascending
	int topCount;
	int* split;           // per column of a subtree: entries from split[j] on are rows above the subtree
	double* acc;          // threads x 3n: a bin's updates of top rows
};

void od_Cholesky_Destroy(od_Cholesky* ch)
{
	if (!ch)
	{
		return;
	}
	od_Free(ch->perm);
	od_Free(ch->colStart);
	od_Free(ch->row);
	od_Free(ch->val);
	od_Free(ch->invDiag);
	od_Free(ch->y);
	od_Free(ch->binStart);
	od_Free(ch->ranges);
	od_Free(ch->top);
	od_Free(ch->split);
	od_Free(ch->acc);
	od_Free(ch);
}

int od_Cholesky_Threads(const od_Cholesky* ch)
{
	return ch->threads;
}

static void od_SortColumn(int* row, double* val, int count)
{
	for (int a = 1; a < count; ++a) // insertion sort: CHOLMOD's columns arrive sorted or nearly
	{
		int r = row[a];
		double v = val[a];
		int b = a;
		for (; b > 0 && row[b - 1] > r; --b)
		{
			row[b] = row[b - 1];
			val[b] = val[b - 1];
		}
		row[b] = r;
		val[b] = v;
	}
}

static od_Status od_CopyFactor(od_Cholesky* ch, const cholmod_factor* f)
{
	int n = ch->n;
	const int* fp = f->p;
	const int* fi = f->i;
	const int* fnz = f->nz;
	const double* fx = f->x;
	size_t offDiagonal = 0;
	for (int j = 0; j < n; ++j)
	{
		offDiagonal += (size_t)fnz[j] - 1;
	}
	ch->perm = od_Alloc(sizeof(int) * (size_t)n);
	ch->colStart = od_Alloc(sizeof(int) * ((size_t)n + 1));
	ch->row = od_Alloc(sizeof(int) * (offDiagonal + 1));
	ch->val = od_Alloc(sizeof(double) * (offDiagonal + 1));
	ch->invDiag = od_Alloc(sizeof(double) * (size_t)n);
	ch->y = od_Alloc(sizeof(double) * 3 * (size_t)n);
	if (!ch->perm || !ch->colStart || !ch->row || !ch->val || !ch->invDiag || !ch->y)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory copying the factor (%zu entries)", offDiagonal);
	}
	memcpy(ch->perm, f->Perm, sizeof(int) * (size_t)n);
	int at = 0;
	for (int j = 0; j < n; ++j)
	{
		int p = fp[j];
		if (fnz[j] < 1 || fi[p] != j) // CHOLMOD keeps the diagonal first in every simplicial column
		{
			return od_Fail(OD_ERROR_INTERNAL, "the factor's column %d does not start with its diagonal", j);
		}
		ch->colStart[j] = at;
		ch->invDiag[j] = 1.0 / fx[p];
		int count = fnz[j] - 1;
		memcpy(ch->row + at, fi + p + 1, sizeof(int) * (size_t)count);
		memcpy(ch->val + at, fx + p + 1, sizeof(double) * (size_t)count);
		od_SortColumn(ch->row + at, ch->val + at, count);
		at += count;
	}
	ch->colStart[n] = at;
	return OD_OK;
}

// ---- The plan ----

typedef struct od_Tree
{
	int* parent;
	int* size;    // columns in the subtree
	double* work; // entries of L in the subtree, plus one per column: the substitutions' cost
} od_Tree;

// The elimination tree; false when the columns are not in postorder (the plan then stays serial).
static bool od_Tree_Build(const od_Cholesky* ch, od_Tree* t)
{
	int n = ch->n;
	for (int j = 0; j < n; ++j)
	{
		int begin = ch->colStart[j], end = ch->colStart[j + 1];
		t->parent[j] = begin < end ? ch->row[begin] : -1; // the first row below the diagonal
		t->size[j] = 1;
		t->work[j] = 1.0 + (double)(end - begin);
	}
	for (int j = 0; j < n; ++j)
	{
		if (t->parent[j] >= 0)
		{
			t->size[t->parent[j]] += t->size[j];
			t->work[t->parent[j]] += t->work[j];
		}
	}
	// Postorder: every subtree's first column lies inside its parent's range, so the size_p columns of p's
	// subtree fill [p - size_p + 1, p] exactly.
	for (int j = 0; j < n; ++j)
	{
		int p = t->parent[j];
		if (p >= 0 && j - t->size[j] + 1 < p - t->size[p] + 1)
		{
			return false;
		}
	}
	return true;
}

// Packs the subtrees `cut` into `bins` bins, largest first onto the lightest bin; returns the heaviest
// bin's work and, with `binOf`, where each went. Sorts `cut` by decreasing work.
static double od_PackBins(const od_Tree* t, int* cut, int count, int bins, double* load, int* binOf)
{
	for (int a = 1; a < count; ++a)
	{
		int v = cut[a], b = a;
		for (; b > 0 && t->work[cut[b - 1]] < t->work[v]; --b)
		{
			cut[b] = cut[b - 1];
		}
		cut[b] = v;
	}
	for (int b = 0; b < bins; ++b)
	{
		load[b] = 0.0;
	}
	double heaviest = 0.0;
	for (int a = 0; a < count; ++a)
	{
		int light = 0;
		for (int b = 1; b < bins; ++b)
		{
			light = load[b] < load[light] ? b : light;
		}
		load[light] += t->work[cut[a]];
		heaviest = load[light] > heaviest ? load[light] : heaviest;
		if (binOf)
		{
			binOf[a] = light;
		}
	}
	return heaviest;
}

#define OD_PLAN_STEPS 4096
#define OD_PLAN_MAX_CUT 1024

// Searches for the cut with the least estimated time (top work + heaviest bin) by splitting, again and
// again, the heaviest subtree of the cut into its children. Returns that time, the serial time in *total
// and the cut in best/bestCount (empty when nothing beats one thread).
static double od_FindCut(const od_Tree* t, int n, int bins, int* cut, int* best, int* bestCount, double* total)
{
	double load[OD_POOL_MAX_THREADS];
	int count = 0;
	double top = 0.0;
	*bestCount = 0;
	*total = 0.0;
	for (int j = 0; j < n; ++j)
	{
		if (t->parent[j] < 0)
		{
			*total += t->work[j];
			if (count == OD_PLAN_MAX_CUT)
			{
				count = -1; // a forest this wide is better left to one thread
			}
			if (count >= 0)
			{
				cut[count++] = j;
			}
		}
	}
	double bestTime = *total;
	for (int step = 0; step < OD_PLAN_STEPS && count > 0 && top < bestTime; ++step)
	{
		double time = top + od_PackBins(t, cut, count, bins, load, NULL);
		if (time < bestTime)
		{
			bestTime = time;
			memcpy(best, cut, sizeof(int) * (size_t)count);
			*bestCount = count;
		}
		int h = cut[0]; // the heaviest, after sorting
		int first = h - t->size[h] + 1;
		double children = 0.0;
		cut[0] = cut[--count];
		for (int c = h - 1; c >= first; c -= t->size[c]) // h's children, last to first
		{
			if (count == OD_PLAN_MAX_CUT)
			{
				return bestTime;
			}
			cut[count++] = c;
			children += t->work[c];
		}
		top += t->work[h] - children;
	}
	return bestTime;
}

static int od_CompareRanges(const void* a, const void* b)
{
	const od_CholRange *ra = a, *rb = b;
	return (ra->lo > rb->lo) - (ra->lo < rb->lo);
}

// Lays the chosen cut out as per-bin column ranges, the top columns and each subtree column's split.
static od_Status od_LayOut(od_Cholesky* ch, const od_Tree* t, int* cut, int count, int bins)
{
	int n = ch->n;
	double load[OD_POOL_MAX_THREADS];
	int* binOf = od_Alloc(sizeof(int) * (size_t)count);
	char* covered = od_AllocZero((size_t)n, 1);
	ch->binStart = od_AllocZero((size_t)bins + 1, sizeof(int));
	ch->ranges = od_Alloc(sizeof(od_CholRange) * (size_t)count);
	ch->split = od_Alloc(sizeof(int) * (size_t)n);
	ch->acc = od_AllocZero(3 * (size_t)n * (size_t)bins, sizeof(double));
	if (!binOf || !covered || !ch->binStart || !ch->ranges || !ch->split || !ch->acc)
	{
		od_Free(binOf);
		od_Free(covered);
		return od_Fail(OD_ERROR_MEMORY, "out of memory planning the parallel substitution");
	}
	od_PackBins(t, cut, count, bins, load, binOf);
	for (int a = 0; a < count; ++a)
	{
		ch->binStart[binOf[a] + 1]++;
	}
	for (int b = 0; b < bins; ++b)
	{
		ch->binStart[b + 1] += ch->binStart[b];
	}
	int cursor[OD_POOL_MAX_THREADS];
	memcpy(cursor, ch->binStart, sizeof(int) * (size_t)bins);
	for (int a = 0; a < count; ++a)
	{
		int hi = cut[a], lo = hi - t->size[hi] + 1;
		ch->ranges[cursor[binOf[a]]++] = (od_CholRange){ lo, hi };
		for (int j = lo; j <= hi; ++j)
		{
			covered[j] = 1;
			int p = ch->colStart[j];
			while (p < ch->colStart[j + 1] && ch->row[p] <= hi)
			{
				++p;
			}
			ch->split[j] = p;
		}
	}
	for (int b = 0; b < bins; ++b)
	{
		qsort(ch->ranges + ch->binStart[b], (size_t)(ch->binStart[b + 1] - ch->binStart[b]), sizeof(od_CholRange),
			  od_CompareRanges);
	}
	ch->topCount = 0;
	for (int j = 0; j < n; ++j)
	{
		ch->topCount += !covered[j];
	}
	ch->top = od_Alloc(sizeof(int) * ((size_t)ch->topCount + 1));
	if (ch->top)
	{
		int k = 0;
		for (int j = 0; j < n; ++j)
		{
			if (!covered[j])
			{
				ch->top[k++] = j;
			}
		}
	}
	od_Free(binOf);
	od_Free(covered);
	return ch->top ? OD_OK : od_Fail(OD_ERROR_MEMORY, "out of memory planning the parallel substitution");
}

// A parallel plan is kept only when it promises at least OD_PLAN_GAIN of the serial time back.
#define OD_PLAN_GAIN 0.15

static od_Status od_Plan(od_Cholesky* ch, int threads)
{
	ch->threads = 1;
	int n = ch->n;
	if (threads < 2 || n < 2)
	{
		return OD_OK;
	}
	threads = threads < OD_POOL_MAX_THREADS ? threads : OD_POOL_MAX_THREADS;
	od_Tree t = { od_Alloc(sizeof(int) * (size_t)n), od_Alloc(sizeof(int) * (size_t)n),
				  od_Alloc(sizeof(double) * (size_t)n) };
	int* cut = od_Alloc(sizeof(int) * OD_PLAN_MAX_CUT);
	int* best = od_Alloc(sizeof(int) * OD_PLAN_MAX_CUT);
	od_Status status = t.parent && t.size && t.work && cut && best
						   ? OD_OK
						   : od_Fail(OD_ERROR_MEMORY, "out of memory planning the parallel substitution");
	if (status == OD_OK && od_Tree_Build(ch, &t))
	{
		int count = 0;
		double total = 0.0;
		double time = od_FindCut(&t, n, threads, cut, best, &count, &total);
		if (count > 0 && time < (1.0 - OD_PLAN_GAIN) * total)
		{
			status = od_LayOut(ch, &t, best, count, threads);
			ch->threads = status == OD_OK ? threads : 1;
		}
	}
	od_Free(t.parent);
	od_Free(t.size);
	od_Free(t.work);
	od_Free(cut);
	od_Free(best);
	return status;
}

od_Status od_Cholesky_Create(cholmod_factor* factor, cholmod_common* common, int threads, od_Cholesky** out)
{
	*out = NULL;
	if (!cholmod_change_factor(CHOLMOD_REAL, 1, 0, 1, 1, factor, common))
	{
		return common->status == CHOLMOD_OUT_OF_MEMORY
				   ? od_Fail(OD_ERROR_MEMORY, "out of memory converting the factor")
				   : od_Fail(OD_ERROR_INTERNAL, "CHOLMOD could not convert the factor (status %d)", common->status);
	}
	od_Cholesky* ch = od_AllocZero(1, sizeof *ch);
	if (!ch)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory copying the factor");
	}
	ch->n = (int)factor->n;
	od_Status status = od_CopyFactor(ch, factor);
	if (status == OD_OK)
	{
		status = od_Plan(ch, threads);
	}
	if (status != OD_OK)
	{
		od_Cholesky_Destroy(ch);
		return status;
	}
	*out = ch;
	return OD_OK;
}

// ---- The substitutions ----

// Column j of L y = b: y_j /= L_jj, then the rows below it; those from `split` on go to `acc` instead.
static void od_Forward(od_Cholesky* ch, int j, int split, double* acc)
{
	double* y = ch->y;
	double s = ch->invDiag[j];
	double y0 = y[3 * j] * s, y1 = y[3 * j + 1] * s, y2 = y[3 * j + 2] * s;
	y[3 * j] = y0;
	y[3 * j + 1] = y1;
	y[3 * j + 2] = y2;
	int end = ch->colStart[j + 1];
	for (int p = ch->colStart[j]; p < split; ++p)
	{
		double* r = y + 3 * ch->row[p];
		double l = ch->val[p];
		r[0] -= l * y0;
		r[1] -= l * y1;
		r[2] -= l * y2;
	}
	for (int p = split; p < end; ++p)
	{
		double* r = acc + 3 * ch->row[p];
		double l = ch->val[p];
		r[0] += l * y0;
		r[1] += l * y1;
		r[2] += l * y2;
	}
}

// Column j of Lᵀ x = y, the rows below it already solved. The backward pass walks the factor from its end
// to its start, and each column from its last entry to its first, so memory is read as one descending
// stream (read column by column ascending, the sawtooth defeats the prefetcher: 2x slower, measured).
// Two sets of sums (odd and even entries) halve the chain of dependent additions.
static void od_Backward(od_Cholesky* ch, int j)
{
	double* y = ch->y;
	double s[6] = { y[3 * j], y[3 * j + 1], y[3 * j + 2], 0.0, 0.0, 0.0 };
	int begin = ch->colStart[j], p = ch->colStart[j + 1] - 1;
	for (; p > begin; p -= 2)
	{
		const double* r = y + 3 * ch->row[p];
		const double* q = y + 3 * ch->row[p - 1];
		double l = ch->val[p], m = ch->val[p - 1];
		s[0] -= l * r[0];
		s[1] -= l * r[1];
		s[2] -= l * r[2];
		s[3] -= m * q[0];
		s[4] -= m * q[1];
		s[5] -= m * q[2];
	}
	if (p == begin)
	{
		const double* r = y + 3 * ch->row[p];
		s[0] -= ch->val[p] * r[0];
		s[1] -= ch->val[p] * r[1];
		s[2] -= ch->val[p] * r[2];
	}
	double d = ch->invDiag[j];
	y[3 * j] = (s[0] + s[3]) * d;
	y[3 * j + 1] = (s[1] + s[4]) * d;
	y[3 * j + 2] = (s[2] + s[5]) * d;
}

static void od_ForwardBin(void* ctx, int bin, int thread)
{
	(void)thread;
	od_Cholesky* ch = ctx;
	double* acc = ch->acc + 3 * (size_t)ch->n * (size_t)bin;
	for (int r = ch->binStart[bin]; r < ch->binStart[bin + 1]; ++r)
	{
		for (int j = ch->ranges[r].lo; j <= ch->ranges[r].hi; ++j)
		{
			od_Forward(ch, j, ch->split[j], acc);
		}
	}
}

static void od_BackwardBin(void* ctx, int bin, int thread)
{
	(void)thread;
	od_Cholesky* ch = ctx;
	for (int r = ch->binStart[bin + 1] - 1; r >= ch->binStart[bin]; --r)
	{
		for (int j = ch->ranges[r].hi; j >= ch->ranges[r].lo; --j)
		{
			od_Backward(ch, j);
		}
	}
}

// One entry of the factor in one substitution pass (three right sides), in nanoseconds: the pool's measure of a
// pass's work (docs/speed.md).
#define OD_ENTRY_NS 0.8

static void od_SolveParallel(od_Cholesky* ch, od_Pool* pool)
{
	size_t stride = 3 * (size_t)ch->n;
	double work = OD_ENTRY_NS * (ch->colStart[ch->n] + ch->n);
	od_Pool_Run(pool, ch->threads, work, od_ForwardBin, ch);
	for (int k = 0; k < ch->topCount; ++k) // the bins' updates of the top rows, in bin order
	{
		double* r = ch->y + 3 * ch->top[k];
		for (int b = 0; b < ch->threads; ++b)
		{
			double* a = ch->acc + stride * (size_t)b + 3 * ch->top[k];
			for (int c = 0; c < 3; ++c)
			{
				r[c] -= a[c];
				a[c] = 0.0;
			}
		}
	}
	for (int k = 0; k < ch->topCount; ++k)
	{
		od_Forward(ch, ch->top[k], ch->colStart[ch->top[k] + 1], NULL);
	}
	for (int k = ch->topCount - 1; k >= 0; --k)
	{
		od_Backward(ch, ch->top[k]);
	}
	od_Pool_Run(pool, ch->threads, work, od_BackwardBin, ch);
}

void od_Cholesky_Solve(od_Cholesky* ch, od_Pool* pool, const double* b, double* x)
{
	int n = ch->n;
	for (int k = 0; k < n; ++k)
	{
		memcpy(ch->y + 3 * k, b + 3 * ch->perm[k], sizeof(double) * 3);
	}
	if (ch->threads > 1 && pool && od_Pool_Threads(pool) == ch->threads)
	{
		od_SolveParallel(ch, pool);
	}
	else
	{
		for (int j = 0; j < n; ++j)
		{
			od_Forward(ch, j, ch->colStart[j + 1], NULL);
		}
		for (int j = n - 1; j >= 0; --j)
		{
			od_Backward(ch, j);
		}
	}
	for (int k = 0; k < n; ++k)
	{
		memcpy(x + 3 * ch->perm[k], ch->y + 3 * k, sizeof(double) * 3);
	}
}

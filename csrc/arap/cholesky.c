// Forward and back substitution with the global matrix's Cholesky factor (the hot half of the global step).
//
// CHOLMOD orders the matrix (AMD, with the elimination tree postordered) and factors it once per change of
// the model; every iteration then substitutes. Here the factor is kept as compressed columns of LLᵀ with
// the diagonal apart (as 1/L_jj) and rows sorted, the three right sides travel interleaved per row so each
// entry of L is read once per substitution, and the permutation is folded into reading b and writing x.
//
// Threads: in postorder the subtree of column j is the column range [j - size_j + 1, j], and two disjoint
// subtrees share no rows but their common ancestors'. The plan cuts the elimination tree into an antichain
// of subtrees and packs them into one bin per thread (largest first): a level. The columns above the cut form a
// tree of their own (a column's ancestors are never in a subtree of the cut), which is cut again into the next
// level, and so on while a level pays; the columns left, the top, go to one thread:
//   forward  L y = b:  level by level, each bin runs its subtrees' columns in order; updates of rows above a
//                      subtree go to the bin's own accumulator; a bin of a later level (and the top, last)
//                      first takes its rows' sums from every accumulator in bin order, then runs in order;
//   backward Lᵀ x = y: the top first, then the levels from the last down, each bin reading only its own rows
//                      and those of later levels.
// The order of every sum depends on the plan alone, so a given thread count gives the same bits each run.
// Each level's cut is searched by its time: its heaviest bin plus the columns above it as the later levels would
// run them, each of those cut by its heaviest bin plus the columns above it on one thread (od_FindCut, deep and
// plain). A level's time counts the threads the pool will give its job (one per OD_POOL_MIN_WORK of its work at
// OD_ENTRY_NS an entry, at least 125,000 entries for two): small factors stay serial (a 1,080-particle beam's;
// a 6,000-particle beam's splits), and the levels of a larger one stop where they would get too few threads. A nested-dissection tree is a tree of separators above its
// subtrees; with one level (before issue 26) the 16-thread plans stopped at 8 subtrees, whose 7 separators (700
// of the 10,000 beam's columns, 2,800 of the 100,000 beam's) ran on one thread, and od_Cholesky_Span bounded the
// substitution at 3.9x and 5.0x. Now the 10,000 beam's plan has 2 levels (5.0x; 6.9x in 5 levels if the pool
// gave every level all its threads), the 100,000 beam's 16 subtrees and the separators above them in 4 levels
// (9.7x), for 3 and 80 ms of planning. Counting the columns above a cut as their heaviest path or their work
// over the threads cut too deep (1.2-2.9x): later levels found only small subtrees.
#include "cholesky.h"

#include "core.h"
#include "pool.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

typedef struct od_CholRange
{
	int begin, end; // positions in `order`; the subtree's root, its largest column, is order[end - 1]
} od_CholRange;

// Levels of a plan at most (each costs two pool jobs a solve).
#define OD_PLAN_LEVELS 8

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
	int threads, levels;
	int* binStart;        // levels x threads + 1, into ranges: level l's bin b from binStart[l * threads + b]
	od_CholRange* ranges; // subtrees, by level, bin and first column
	int* order;           // n: the subtrees' columns, ascending in each, in the order of ranges; then the top's
	int topStart;         // where the top begins in order
	double levelWork[OD_PLAN_LEVELS]; // the level's share of a pass (od_ColumnsWork), for the pool
	int* split;           // per column of a subtree: entries from split[j] on are rows above the subtree
	double* acc;          // threads x 3n: a bin's updates of rows above its subtrees
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
	od_Free(ch->order);
	od_Free(ch->split);
	od_Free(ch->acc);
	od_Free(ch);
}

int od_Cholesky_Threads(const od_Cholesky* ch)
{
	return ch->threads;
}

// Column j's share of a substitution pass: one, and one per entry below the diagonal.
static double od_ColumnWork(const od_Cholesky* ch, int j)
{
	return 1.0 + (double)(ch->colStart[j + 1] - ch->colStart[j]);
}

// A pool job's time, in entries: `work` entries in `tasks` tasks (the longest `longest`) on the threads the pool
// gives it for `told` entries of work (pool.h: one per OD_POOL_MIN_WORK, at least one, at most one per task).
static double od_JobTime(double told, double work, double longest, int tasks)
{
	double filled = floor(told * OD_ENTRY_NS / OD_POOL_MIN_WORK);
	double threads = filled < 1.0 ? 1.0 : filled < tasks ? filled : tasks;
	return longest > work / threads ? longest : work / threads;
}

void od_Cholesky_Span(const od_Cholesky* ch, double* serial, double* span)
{
	double permute = 2.0 * ch->n; // b read and x written through the permutation, on the calling thread
	*serial = permute + 2.0 * (double)(ch->n + ch->colStart[ch->n]);
	*span = *serial;
	if (ch->threads < 2)
	{
		return;
	}
	*span = permute;
	for (int l = 0; l < ch->levels; ++l)
	{
		double forward = 0.0, backward = 0.0, pulls = 0.0;
		for (int b = 0; b < ch->threads; ++b)
		{
			double work = 0.0, columns = 0.0;
			for (int r = ch->binStart[l * ch->threads + b]; r < ch->binStart[l * ch->threads + b + 1]; ++r)
			{
				for (int p = ch->ranges[r].begin; p < ch->ranges[r].end; ++p)
				{
					work += od_ColumnWork(ch, ch->order[p]);
				}
				columns += ch->ranges[r].end - ch->ranges[r].begin;
			}
			double pull = l > 0 ? columns * ch->threads : 0.0; // the sums taken from every accumulator
			forward = work + pull > forward ? work + pull : forward;
			backward = work > backward ? work : backward;
			pulls += pull;
		}
		double work = ch->levelWork[l];
		*span += od_JobTime(work, work + pulls, forward, ch->threads) + od_JobTime(work, work, backward, ch->threads);
	}
	for (int p = ch->topStart; p < ch->n; ++p)
	{
		*span += 2.0 * od_ColumnWork(ch, ch->order[p]) + ch->threads;
	}
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
	int* size;    // nodes in the subtree
	double* work; // entries of L in the subtree, plus one per column: the substitutions' cost
} od_Tree;

// The elimination tree of the columns cols[0..m) (ascending, every ancestor of one of them among them): node k
// is column cols[k], node[cols[k]] = k. False when they are not in postorder (the plan then stays serial).
static bool od_Tree_Build(const od_Cholesky* ch, const int* cols, int m, int* node, od_Tree* t)
{
	for (int k = 0; k < m; ++k)
	{
		node[cols[k]] = k;
	}
	for (int k = 0; k < m; ++k)
	{
		int j = cols[k], begin = ch->colStart[j];
		t->parent[k] = begin < ch->colStart[j + 1] ? node[ch->row[begin]] : -1; // the first row below the diagonal
		t->size[k] = 1;
		t->work[k] = od_ColumnWork(ch, j);
	}
	for (int k = 0; k < m; ++k)
	{
		if (t->parent[k] >= 0)
		{
			t->size[t->parent[k]] += t->size[k];
			t->work[t->parent[k]] += t->work[k];
		}
	}
	// Postorder: every subtree's first node lies inside its parent's range, so the size_p nodes of p's
	// subtree fill [p - size_p + 1, p] exactly.
	for (int k = 0; k < m; ++k)
	{
		int p = t->parent[k];
		if (p >= 0 && k - t->size[k] + 1 < p - t->size[p] + 1)
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
// A level is kept only when it promises at least OD_PLAN_GAIN of its columns' serial time back.
#define OD_PLAN_GAIN 0.15
// The deep search (od_FindCut) looks past the first cut only at cuts of at most this many subtrees a bin.
#define OD_PLAN_DEEP 4

// The search's view of the levels above a cut (od_FindCut with `deep`): the columns the tree is over, a second
// tree for the columns above a cut and its own cut, and marks (n, zero between uses).
typedef struct od_Deep
{
	const od_Cholesky* ch;
	const int* cols;
	od_Tree above;
	int *aboveCols, *node, *cut, *best;
	char* mark;
	int levels; // the levels left for those above
} od_Deep;

static double od_FindCut(const od_Tree* t, int n, int bins, int* cut, int* best, int* bestCount, double* total,
						 double* bestTop, od_Deep* deep);

// Drops the subtrees `cut` from the tree's columns cols[0..m); returns the columns left.
static int od_DropSubtrees(const od_Tree* t, int* cols, int m, const int* cut, int count, char* mark)
{
	for (int a = 0; a < count; ++a)
	{
		memset(mark + cut[a] - t->size[cut[a]] + 1, 1, (size_t)t->size[cut[a]]);
	}
	int left = 0;
	for (int k = 0; k < m; ++k)
	{
		cols[left] = cols[k];
		left += !mark[k];
		mark[k] = 0;
	}
	return left;
}

// The time of the columns above the cut of t, as od_CutLevels would run them: levels cut by their time on one
// thread while they pay, then the top.
static double od_AboveTime(od_Deep* deep, const od_Tree* t, const int* cut, int count, int n, int bins)
{
	memcpy(deep->aboveCols, deep->cols, sizeof(int) * (size_t)n);
	int m = od_DropSubtrees(t, deep->aboveCols, n, cut, count, deep->mark);
	double time = 0.0;
	for (int level = 0; level < deep->levels && od_Tree_Build(deep->ch, deep->aboveCols, m, deep->node, &deep->above);
		 ++level)
	{
		int found = 0;
		double total = 0.0, top = 0.0;
		double levelTime = od_FindCut(&deep->above, m, bins, deep->cut, deep->best, &found, &total, &top, NULL);
		if (found == 0 || levelTime >= (1.0 - OD_PLAN_GAIN) * total)
		{
			break;
		}
		time += levelTime - top;
		m = od_DropSubtrees(&deep->above, deep->aboveCols, m, deep->best, found, deep->mark);
	}
	for (int k = 0; k < m; ++k)
	{
		time += od_ColumnWork(deep->ch, deep->aboveCols[k]);
	}
	return time;
}

// Searches for the cut with the least estimated time by splitting, again and again, the heaviest subtree of the
// cut into its children (below the chain of single children it starts with: a chain's columns run in order
// wherever they go). The time: the heaviest bin plus the columns above the cut, on one thread, or with
// `deep` as the levels after it would run them (evaluated where the cut grew). Returns that time, the serial
// time in *total, the cut in best/bestCount (empty when nothing beats one thread) and the work above it.
static double od_FindCut(const od_Tree* t, int n, int bins, int* cut, int* best, int* bestCount, double* total,
						 double* bestTop, od_Deep* deep)
{
	double load[OD_POOL_MAX_THREADS];
	int count = 0;
	bool branched = true; // the last split left more subtrees than before: worth a deep look
	double top = 0.0;
	*bestCount = 0;
	*total = 0.0;
	*bestTop = 0.0;
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
	for (int step = 0;
		 step < OD_PLAN_STEPS && count > 0 && (deep ? step == 0 || count <= OD_PLAN_DEEP * bins : top < bestTime);
		 ++step)
	{
		double below = *total - top; // the cut's subtrees, one pool job
		double time = top + od_JobTime(below, below, od_PackBins(t, cut, count, bins, load, NULL), bins);
		if (deep && branched)
		{
			time += od_AboveTime(deep, t, cut, count, n, bins) - top;
		}
		if ((!deep || branched) && time < bestTime)
		{
			bestTime = time;
			memcpy(best, cut, sizeof(int) * (size_t)count);
			*bestCount = count;
			*bestTop = top;
		}
		int h = cut[0]; // the heaviest, after sorting
		int before = count;
		cut[0] = cut[--count];
		for (; t->size[h] > 1 && t->size[h - 1] == t->size[h] - 1; --h) // one child: down the chain in one step
		{
			top += t->work[h] - t->work[h - 1];
		}
		int first = h - t->size[h] + 1;
		double children = 0.0;
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
		branched = count > before;
	}
	return bestTime;
}

static int od_CompareRanges(const void* a, const void* b)
{
	const od_CholRange *ra = a, *rb = b;
	return (ra->begin > rb->begin) - (ra->begin < rb->begin);
}

// Lays out level l: the cut's subtrees (nodes of t over cols) packed into the bins, each bin's by first column,
// their columns appended to order from *at; sets their splits.
static void od_LayOutLevel(od_Cholesky* ch, const od_Tree* t, const int* cols, int* cut, int count, int l, int* binOf,
						   int* at)
{
	int bins = ch->threads;
	double load[OD_POOL_MAX_THREADS];
	int cursor[OD_POOL_MAX_THREADS];
	int* binStart = ch->binStart + l * bins; // binStart[0]: where the level before ended
	od_PackBins(t, cut, count, bins, load, binOf);
	for (int b = 0; b < bins; ++b)
	{
		binStart[b + 1] = binStart[b];
		for (int a = 0; a < count; ++a)
		{
			binStart[b + 1] += binOf[a] == b;
		}
		cursor[b] = binStart[b];
	}
	for (int a = 0; a < count; ++a) // as node ranges first
	{
		ch->ranges[cursor[binOf[a]]++] = (od_CholRange){ cut[a] - t->size[cut[a]] + 1, cut[a] + 1 };
	}
	ch->levelWork[l] = 0.0;
	for (int b = 0; b < bins; ++b)
	{
		qsort(ch->ranges + binStart[b], (size_t)(binStart[b + 1] - binStart[b]), sizeof(od_CholRange),
			  od_CompareRanges);
		for (int r = binStart[b]; r < binStart[b + 1]; ++r)
		{
			int begin = *at, root = cols[ch->ranges[r].end - 1];
			for (int k = ch->ranges[r].begin; k < ch->ranges[r].end; ++k)
			{
				int j = cols[k], p = ch->colStart[j];
				while (p < ch->colStart[j + 1] && ch->row[p] <= root)
				{
					++p;
				}
				ch->split[j] = p;
				ch->order[(*at)++] = j;
				ch->levelWork[l] += od_ColumnWork(ch, j);
			}
			ch->ranges[r] = (od_CholRange){ begin, *at };
		}
	}
}

// Cuts levels from the whole tree, then from the columns above each cut, while they pay; the rest is the top.
// Returns the levels made.
static int od_CutLevels(od_Cholesky* ch, od_Tree* t, int* cols, int* cut, int* best, int* binOf, od_Deep* deep)
{
	int m = ch->n, at = 0, levels = 0;
	for (int j = 0; j < m; ++j)
	{
		cols[j] = j;
	}
	ch->binStart[0] = 0;
	while (levels < OD_PLAN_LEVELS && od_Tree_Build(ch, cols, m, deep->node, t))
	{
		int count = 0;
		double total = 0.0, top = 0.0;
		deep->levels = OD_PLAN_LEVELS - levels - 1;
		double time = od_FindCut(t, m, ch->threads, cut, best, &count, &total, &top, deep);
		if (count == 0 || time >= (1.0 - OD_PLAN_GAIN) * total)
		{
			break;
		}
		od_LayOutLevel(ch, t, cols, best, count, levels++, binOf, &at);
		m = od_DropSubtrees(t, cols, m, best, count, deep->mark);
	}
	ch->topStart = at;
	memcpy(ch->order + at, cols, sizeof(int) * (size_t)m);
	return levels;
}

static od_Tree od_Tree_Alloc(int n)
{
	return (od_Tree){ od_Alloc(sizeof(int) * (size_t)n), od_Alloc(sizeof(int) * (size_t)n),
					  od_Alloc(sizeof(double) * (size_t)n) };
}

static void od_Tree_Free(od_Tree* t)
{
	od_Free(t->parent);
	od_Free(t->size);
	od_Free(t->work);
}

static od_Status od_Plan(od_Cholesky* ch, int threads)
{
	ch->threads = 1;
	int n = ch->n;
	if (threads < 2 || n < 2)
	{
		return OD_OK;
	}
	threads = threads < OD_POOL_MAX_THREADS ? threads : OD_POOL_MAX_THREADS;
	od_Tree t = od_Tree_Alloc(n);
	int* cut = od_Alloc(sizeof(int) * OD_PLAN_MAX_CUT);
	int* best = od_Alloc(sizeof(int) * OD_PLAN_MAX_CUT);
	int* binOf = od_Alloc(sizeof(int) * OD_PLAN_MAX_CUT);
	int* cols = od_Alloc(sizeof(int) * (size_t)n);
	od_Deep deep = { ch, cols, od_Tree_Alloc(n), od_Alloc(sizeof(int) * (size_t)n), od_Alloc(sizeof(int) * (size_t)n),
					 od_Alloc(sizeof(int) * OD_PLAN_MAX_CUT), od_Alloc(sizeof(int) * OD_PLAN_MAX_CUT),
					 od_AllocZero((size_t)n, 1), 0 };
	ch->binStart = od_Alloc(sizeof(int) * ((size_t)OD_PLAN_LEVELS * (size_t)threads + 1));
	ch->ranges = od_Alloc(sizeof(od_CholRange) * OD_PLAN_LEVELS * OD_PLAN_MAX_CUT);
	ch->order = od_Alloc(sizeof(int) * (size_t)n);
	ch->split = od_Alloc(sizeof(int) * (size_t)n);
	od_Status status = OD_OK;
	if (!t.parent || !t.size || !t.work || !cut || !best || !binOf || !cols || !deep.above.parent ||
		!deep.above.size || !deep.above.work || !deep.aboveCols || !deep.node || !deep.cut || !deep.best ||
		!deep.mark || !ch->binStart || !ch->ranges || !ch->order || !ch->split)
	{
		status = od_Fail(OD_ERROR_MEMORY, "out of memory planning the parallel substitution");
	}
	if (status == OD_OK)
	{
		ch->threads = threads;
		ch->levels = od_CutLevels(ch, &t, cols, cut, best, binOf, &deep);
		ch->acc = ch->levels > 0 ? od_AllocZero(3 * (size_t)n * (size_t)threads, sizeof(double)) : NULL;
		if (ch->levels > 0 && !ch->acc)
		{
			status = od_Fail(OD_ERROR_MEMORY, "out of memory planning the parallel substitution");
		}
		ch->threads = ch->acc ? threads : 1;
	}
	od_Tree_Free(&t);
	od_Tree_Free(&deep.above);
	od_Free(cut);
	od_Free(best);
	od_Free(binOf);
	od_Free(cols);
	od_Free(deep.aboveCols);
	od_Free(deep.node);
	od_Free(deep.cut);
	od_Free(deep.best);
	od_Free(deep.mark);
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

// Row j takes the sums of the bins' updates from every accumulator, in bin order, and clears them.
static void od_Gather(od_Cholesky* ch, int j)
{
	double* r = ch->y + 3 * j;
	double* a = ch->acc + 3 * j;
	for (int b = 0; b < ch->threads; ++b, a += 3 * (size_t)ch->n)
	{
		for (int c = 0; c < 3; ++c)
		{
			r[c] -= a[c];
			a[c] = 0.0;
		}
	}
}

typedef struct od_CholJob
{
	od_Cholesky* ch;
	int level;
} od_CholJob;

static void od_ForwardBin(void* ctx, int bin, int thread)
{
	(void)thread;
	const od_CholJob* job = ctx;
	od_Cholesky* ch = job->ch;
	double* acc = ch->acc + 3 * (size_t)ch->n * (size_t)bin;
	int at = job->level * ch->threads + bin;
	const od_CholRange* first = ch->ranges + ch->binStart[at];
	const od_CholRange* end = ch->ranges + ch->binStart[at + 1];
	for (const od_CholRange* r = first; job->level > 0 && r < end; ++r) // rows with updates from earlier levels
	{
		for (int p = r->begin; p < r->end; ++p)
		{
			od_Gather(ch, ch->order[p]);
		}
	}
	for (const od_CholRange* r = first; r < end; ++r)
	{
		for (int p = r->begin; p < r->end; ++p)
		{
			od_Forward(ch, ch->order[p], ch->split[ch->order[p]], acc);
		}
	}
}

static void od_BackwardBin(void* ctx, int bin, int thread)
{
	(void)thread;
	const od_CholJob* job = ctx;
	od_Cholesky* ch = job->ch;
	int at = job->level * ch->threads + bin;
	for (int r = ch->binStart[at + 1] - 1; r >= ch->binStart[at]; --r)
	{
		for (int p = ch->ranges[r].end - 1; p >= ch->ranges[r].begin; --p)
		{
			od_Backward(ch, ch->order[p]);
		}
	}
}

static void od_SolveParallel(od_Cholesky* ch, od_Pool* pool)
{
	od_CholJob job = { ch, 0 };
	for (job.level = 0; job.level < ch->levels; ++job.level)
	{
		od_Pool_Run(pool, ch->threads, OD_ENTRY_NS * ch->levelWork[job.level], od_ForwardBin, &job);
	}
	for (int p = ch->topStart; p < ch->n; ++p)
	{
		od_Gather(ch, ch->order[p]);
	}
	for (int p = ch->topStart; p < ch->n; ++p)
	{
		od_Forward(ch, ch->order[p], ch->colStart[ch->order[p] + 1], NULL);
	}
	for (int p = ch->n - 1; p >= ch->topStart; --p)
	{
		od_Backward(ch, ch->order[p]);
	}
	for (job.level = ch->levels - 1; job.level >= 0; --job.level)
	{
		od_Pool_Run(pool, ch->threads, OD_ENTRY_NS * ch->levelWork[job.level], od_BackwardBin, &job);
	}
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

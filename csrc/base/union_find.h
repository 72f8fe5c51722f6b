// Disjoint sets over 0..n-1 in an int array (parent[i] = i initially). The smaller root always wins, so
// the representative of a set is its smallest element and results do not depend on the union order.
#pragma once

static inline int od_Find(int* parent, int i)
{
	while (parent[i] != i)
	{
		parent[i] = parent[parent[i]];
		i = parent[i];
	}
	return i;
}

// Joins the sets of a and b; returns 1 when they were different.
static inline int od_Union(int* parent, int a, int b)
{
	a = od_Find(parent, a);
	b = od_Find(parent, b);
	if (a == b)
	{
		return 0;
	}
	if (a < b)
	{
		parent[b] = a;
	}
	else
	{
		parent[a] = b;
	}
	return 1;
}

static inline void od_UnionInit(int* parent, int n)
{
	for (int i = 0; i < n; ++i)
	{
		parent[i] = i;
	}
}

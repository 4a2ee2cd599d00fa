// Sequential k-opt moves in the notation of Helsgaun (2009), "General k-opt submoves for
// the Lin-Kernighan TSP heuristic", Math. Prog. Comp. 1:119-163.
//
// A move is given by t[1..2k]: it removes the tour edges (t1,t2), (t3,t4), ..., (t2k-1,t2k)
// and adds (t2,t3), (t4,t5), ..., (t2k,t1). The t's must be distinct nodes and each
// (t2i-1, t2i) a tour edge.
//
// Feasibility (section 5.1 of the paper): sort the t's by tour position; the removed edges
// cut the tour into k segments; follow segment, added edge, segment, ... and the move is
// feasible iff one cycle visits all k segments. O(k log k), no tour modification.
//
// Execution (section 5.3): the new tour is a signed permutation of the k segments (segment
// 0 fixed). A breadth-first search over block reversals, done once per k at start-up,
// gives a shortest sequence of reversals for every signed permutation; each reversal of
// segments is one Tour::Reverse (a 2-opt move).
#pragma once

#include "tsp/tour.h"

namespace mound::tsp {

constexpr int kMaxK = 5;

// True iff the k-opt move t[1..2k] (t[0] unused) yields a Hamiltonian cycle.
bool FeasibleKOptMove(const Tour& tour, const int* t, int k);

// Applies a feasible k-opt move with at most k reversals.
void MakeKOptMove(Tour& tour, const int* t, int k);

}  // namespace mound::tsp

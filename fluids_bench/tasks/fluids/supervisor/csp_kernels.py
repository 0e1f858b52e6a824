"""The velocity planner's constraint problem solved in compiled code (numba).

The planner's CSP has one variable per agent in a binary constraint, its allowed candidate
indices as the domain, and "not conflict[p, x, y]" per pair. Its reference is
python-constraint2's `OptimizedBacktrackingSolver` with the variables in priority order, and
`solve` replays that solver's search step for step, so it returns the same assignment,
not merely a valid one: variables in the given order; a variable's values tried from the end
of its domain list; forward checking that hides the values of a constraint's one unassigned
variable that clash with the assignment (in the domain's list order) and, on backtracking,
appends them back at the end of the list (so a domain's order can change during the search,
and the values tried next follow that order; on random dense instances this gives another
answer than a plain lexicographic search in about 4 % of cases).
`tests/tasks/fluids/supervisor/test_csp_kernel.py` checks the assignment against
python-constraint2 on planner instances recorded from seeded episodes and on random ones.

Pure integer logic over arrays: the same on every CPU.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fluids_bench.core.compiled import callee, kernel


@njit(cache=True, nogil=True, inline="always")
def _hide(dom, dlen, hid, hlen, v, value):  # pragma: no cover (compiled)
    """Domain.hideValue: remove `value` from v's list (shifting the rest) onto its stack."""
    at = 0
    while dom[v, at] != value:
        at += 1
    for i in range(at, dlen[v] - 1):
        dom[v, i] = dom[v, i + 1]
    dlen[v] -= 1
    hid[v, hlen[v]] = value
    hlen[v] += 1


@njit(cache=True, nogil=True, inline="always")
def _push(states, slen, dlen, v):  # pragma: no cover (compiled)
    """Domain.pushState: remember v's current length."""
    states[v, slen[v]] = dlen[v]
    slen[v] += 1


@njit(cache=True, nogil=True, inline="always")
def _pop(states, slen, dom, dlen, hid, hlen, v):  # pragma: no cover (compiled)
    """Domain.popState: the values hidden since the matching push go back, at the end, in the
    order they were hidden."""
    slen[v] -= 1
    diff = states[v, slen[v]] - dlen[v]
    if diff:
        for i in range(hlen[v] - diff, hlen[v]):
            dom[v, dlen[v]] = hid[v, i]
            dlen[v] += 1
        hlen[v] -= diff


@njit(cache=True, nogil=True, inline="always")
def _check(
    cons, first, second, bad, assigned, value, forward, dom, dlen, hid, hlen, snapshot
):  # pragma: no cover (compiled)
    """The constraints of `var` (indices `cons`, in the order they were added), after it
    got its value: a constraint with both variables assigned must hold; with one unassigned
    (and `forward`: some domain was pushed) that variable's clashing values are hidden, and
    an emptied domain fails it. False at the first failing constraint. `snapshot` (K,):
    scratch for the domain's list as it was before hiding."""
    for c in cons:
        a, b = first[c], second[c]
        if assigned[a] and assigned[b]:
            if bad[c, value[a], value[b]]:
                return False
            continue
        if not forward:
            continue
        u = b if assigned[a] else a
        if dlen[u]:
            n_snap = dlen[u]
            for i in range(n_snap):
                snapshot[i] = dom[u, i]
            for x in snapshot[:n_snap]:
                clash = bad[c, value[a], x] if u == b else bad[c, x, value[b]]
                if clash:
                    _hide(dom, dlen, hid, hlen, u, x)
        if not dlen[u]:
            return False
    return True


@callee
def solve(order, allowed, first, second, bad):  # pragma: no cover (compiled)
    """The first solution of the planner's CSP as python-constraint2's
    `OptimizedBacktrackingSolver` (forward checking on) finds it.

    order (V,): the variables in the order they are assigned; allowed (V, K) bool: each
    variable's domain, listed ascending; first, second, bad: the binary constraints in the
    order they were added, variable indices and bad[c, x, y] (the pair may not take x, y).
    Returns (found, value (V,)).
    """
    n, k = allowed.shape
    dom, dlen = np.zeros((n, k), np.int64), np.zeros(n, np.int64)
    for v in range(n):
        for x in range(k):
            if allowed[v, x]:
                dom[v, dlen[v]] = x
                dlen[v] += 1
    hid, hlen = np.zeros((n, k), np.int64), np.zeros(n, np.int64)
    states, slen = np.zeros((n, n + 2), np.int64), np.zeros(n, np.int64)
    cons_of = np.zeros((n, len(first)), np.int64)  # each variable's constraints, in order
    n_cons = np.zeros(n, np.int64)
    for c in range(len(first)):
        for v in (first[c], second[c]):
            cons_of[v, n_cons[v]] = c
            n_cons[v] += 1
    assigned, value = np.zeros(n, np.bool_), np.zeros(n, np.int64)
    # the queue of levels: variable, the values left to try, the domains pushed at that level
    q_var = np.zeros(n, np.int64)
    q_values, q_len = np.zeros((n, k), np.int64), np.zeros(n, np.int64)
    q_push = np.zeros((n, n), np.bool_)
    depth = 0
    values, n_values = np.zeros(k, np.int64), 0
    push = np.zeros(n, np.bool_)
    snapshot = np.empty(k, np.int64)  # _check's scratch
    while True:
        var = -1
        for v in order:
            if not assigned[v]:
                var = v
                break
        if var < 0:
            return True, value  # every variable assigned
        n_values = dlen[var]
        for i in range(n_values):
            values[i] = dom[var, i]
        forward = False
        for v in range(n):
            push[v] = not assigned[v] and v != var
            forward |= push[v]
        while True:
            if n_values == 0:  # back to the last level with values left
                assigned[var] = False
                resumed = False
                while depth > 0:
                    depth -= 1
                    var = q_var[depth]
                    n_values = q_len[depth]
                    for i in range(n_values):
                        values[i] = q_values[depth, i]
                    forward = False
                    for v in range(n):
                        push[v] = q_push[depth, v]
                        forward |= push[v]
                        if push[v]:
                            _pop(states, slen, dom, dlen, hid, hlen, v)
                    if n_values:
                        resumed = True
                        break
                    assigned[var] = False
                if not resumed:
                    return False, value
            n_values -= 1
            assigned[var], value[var] = True, values[n_values]
            for v in range(n):
                if push[v]:
                    _push(states, slen, dlen, v)
            cons = cons_of[var, : n_cons[var]]
            if _check(
                cons, first, second, bad, assigned, value, forward, dom, dlen, hid, hlen, snapshot
            ):
                break
            for v in range(n):
                if push[v]:
                    _pop(states, slen, dom, dlen, hid, hlen, v)
        q_var[depth] = var
        q_len[depth] = n_values
        for i in range(n_values):
            q_values[depth, i] = values[i]
        for v in range(n):
            q_push[depth, v] = push[v]
        depth += 1


@callee
def priority_order(agents, s, offset, front, route, enter_s):  # pragma: no cover (compiled)
    """Positions in `agents` in the order the CSP assigns them (right of way first): agents
    whose front is in or past their route's shared zone (`enter_s`) first, the furthest in
    first; then the others, nearest to it first; ties by world index."""
    n = len(agents)
    inside = np.zeros(n, np.bool_)
    key_in, key_out = np.empty(n), np.empty(n)
    for a in range(n):
        ag = agents[a]
        enter = enter_s[route[ag] if route[ag] >= 0 else route[ag] + len(enter_s)]
        rs = s[ag] + offset[ag] + front[ag]
        inside[a] = rs >= enter
        key_in[a] = enter - rs if inside[a] else np.inf
        key_out[a] = -np.inf if inside[a] else enter - rs
    order = np.arange(n)
    for i in range(1, n):  # insertion sort on (not inside, key_in, key_out, index)
        a = order[i]
        j = i - 1
        while j >= 0:
            b = order[j]
            if not _before(
                inside[a], key_in[a], key_out[a], agents[a],
                inside[b], key_in[b], key_out[b], agents[b],
            ):  # fmt: skip
                break
            order[j + 1] = b
            j -= 1
        order[j + 1] = a
    return order


# scalars, not the arrays: with the four arrays as arguments (inlined or not) the comparisons
# took 2.3 us of a 2.5 us sort of 13 agents
@njit(cache=True, nogil=True, inline="always")
def _before(in_a, k_in_a, k_out_a, ag_a, in_b, k_in_b, k_out_b, ag_b):  # pragma: no cover
    """Whether an agent with these keys (inside, key_in, key_out, world index) goes before
    one with those (`priority_order`)."""
    if in_a != in_b:
        return in_a
    if k_in_a != k_in_b:
        return k_in_a < k_in_b
    if k_out_a != k_out_b:
        return k_out_a < k_out_b
    return ag_a < ag_b


@njit(cache=True, nogil=True, inline="always")
def _fastest_allowed(allowed):  # pragma: no cover (compiled)
    """Each agent's highest allowed candidate (the last one where none is)."""
    n, k = allowed.shape
    choice = np.full(n, k - 1)
    for a in range(n):
        for x in range(k - 1, -1, -1):
            if allowed[a, x]:
                choice[a] = x
                break
    return choice


@njit(cache=True, nogil=True, inline="always")
def _binds(choice, pairs, conflict):  # pragma: no cover (compiled)
    """Some constraint clashes at `choice`: the CSP matters."""
    for p in range(len(pairs)):
        if conflict[p, choice[pairs[p, 0]], choice[pairs[p, 1]]]:
            return True
    return False


@callee
def _solve_into(choice, priority, allowed, pairs, conflict):  # pragma: no cover (compiled)
    """The CSP's solution written into `choice` (`solve`; variables: the agents in
    some pair, in the `priority` order, added in ascending position as their domains);
    False where it has none."""
    n, k = allowed.shape
    index = np.full(n, -1)
    count = 0
    for a in range(n):  # the variables in ascending position: python-constraint2's dict order
        for p in range(len(pairs)):
            if pairs[p, 0] == a or pairs[p, 1] == a:
                index[a] = count
                count += 1
                break
    domains = np.zeros((count, k), np.bool_)
    for a in range(n):
        if index[a] >= 0:
            for x in range(k):
                domains[index[a], x] = allowed[a, x]
    order, m = np.empty(count, np.int64), 0
    for a in priority:
        if index[a] >= 0:
            order[m] = index[a]
            m += 1
    first, second = np.empty(len(pairs), np.int64), np.empty(len(pairs), np.int64)
    for p in range(len(pairs)):
        first[p], second[p] = index[pairs[p, 0]], index[pairs[p, 1]]
    found, value = solve(order, domains, first, second, conflict)
    for a in range(n):
        if index[a] >= 0:
            choice[a] = value[index[a]]
    return found


@kernel
def choose(priority, allowed, pairs, conflict):  # pragma: no cover (compiled)
    """Each agent's candidate (A,): its fastest allowed one, unless a binding constraint
    (`pairs` (P, 2) positions, `conflict` (P, K, K)) clashes there; then the CSP's solution
    with the variables in the `priority` order. Returns (choice, solved)."""
    choice = _fastest_allowed(allowed)
    if not _binds(choice, pairs, conflict):
        return choice, True
    return choice, _solve_into(choice, priority, allowed, pairs, conflict)


@callee
def plan_choice(
    agents, s, offset, front, route, enter_s, allowed, pairs, conflict
):  # pragma: no cover (compiled)
    """`choose` for `agents` (world indices), with the priority order
    (`priority_order`) worked out only when a constraint binds."""
    choice = _fastest_allowed(allowed)
    if not _binds(choice, pairs, conflict):
        return choice, True
    priority = priority_order(agents, s, offset, front, route, enter_s)
    return choice, _solve_into(choice, priority, allowed, pairs, conflict)

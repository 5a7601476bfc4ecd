#!/usr/bin/python3
"""Solves the QPs of a problem file with cvxopt (reference for the C++ solver's tests).

Input per problem: "n m", then H (column-major), g, A (row-major, empty if m = 0), lb, ub, lbA, ubA
each on one line. Output per problem: status and x on one line.
"""
import math
import sys

import cvxopt
from cvxopt import matrix, solvers

solvers.options.update({"show_progress": False, "abstol": 1e-12, "reltol": 1e-12, "feastol": 1e-12,
                        "maxiters": 200})


def floats(line):
    return [float(t) for t in line.split()]


def main(src, dst):
    lines = [l for l in open(src).read().split("\n")]
    out = []
    i = 0
    while i < len(lines) and lines[i].strip():
        n, m = (int(t) for t in lines[i].split())
        H = floats(lines[i + 1])
        g = floats(lines[i + 2])
        A = floats(lines[i + 3])
        lb, ub, lbA, ubA = (floats(lines[i + k]) for k in range(4, 8))
        i += 8
        G, h, Aeq, beq = [], [], [], []
        rows = [[1.0 if c == r else 0.0 for c in range(n)] for r in range(n)]
        rows += [A[r * n:(r + 1) * n] for r in range(m)]
        lo = lb + lbA
        hi = ub + ubA
        for row, l, u in zip(rows, lo, hi):
            if l == u:
                Aeq.append(row); beq.append(l)
                continue
            if not math.isinf(u):
                G.append(row); h.append(u)
            if not math.isinf(l):
                G.append([-v for v in row]); h.append(-l)
        P = matrix(H, (n, n))
        q = matrix(g, (n, 1))
        args = {}
        if G:
            args["G"] = matrix([v for r in G for v in r], (n, len(G))).T
            args["h"] = matrix(h, (len(h), 1))
        if Aeq:
            args["A"] = matrix([v for r in Aeq for v in r], (n, len(Aeq))).T
            args["b"] = matrix(beq, (len(beq), 1))
        try:
            sol = solvers.qp(P, q, **args)
            status = sol["status"]
            x = list(sol["x"])
        except ValueError:
            status, x = "error", [0.0] * n
        out.append(status + " " + " ".join(repr(v) for v in x))
    open(dst, "w").write("\n".join(out) + "\n")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])

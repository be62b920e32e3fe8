#!/usr/bin/env node
// An implementation of the tstarg JSON-lines protocol 1.0 in JavaScript (node >= 18, no packages):
// poisson_tensor for any Lie algebra.
//
// Certify:   tstarg certify --cmd "node examples/js/tstarg_client.mjs" --max-examples 10
//
// One request per line on stdin ({"id", "method", "args"}), one reply per line on stdout
// ({"id", "result"} or {"id", "error"}); schema: reports/schema/ (request and reply .schema.json).
//
// The mathematics (CONVENTIONS.md of tstarg; the paper's equation vier9):
//   ad_x[m][b] = x^a f^m_ab,        L(g, e) = phi1(-ad_x)^-1,    phi1(A) = (e^A - 1) / A,
//   S_ab = pi_m f^m_ab - Theta_ab,  Phi = 1 + S Upsilon,          Psi = 1 + Upsilon S = Phi^T,
//   -W^-1 = [[-Upsilon Phi^-1, Psi^-1], [-Phi^-1, -S Psi^-1]]   (vier9),
//   P = T (-W^-1) T^T with T = diag(L(g, e), 1),                 P[i][j] = {z_i, z_j}, z = (x, pi).
// phi1(A) is the top-right block of exp([[A, 1], [0, 0]]) (Van Loan), by scaling and squaring with a
// Taylor polynomial. The exact P is antisymmetric; we return (P - P^T) / 2, which is no farther from
// it than the computed P. A point where Phi is singular to working precision (the degenerate set,
// Delta = det Phi = 0, vier7) is refused with "ValueError: ...", as the protocol asks.
import { createInterface } from "node:readline";

const EPS = Number.EPSILON;
const zeros = (n, m) => Array.from({ length: n }, () => new Array(m).fill(0));
const eye = (n) => zeros(n, n).map((row, i) => { row[i] = 1; return row; });
const matmul = (A, B) => A.map((row) => B[0].map((_, j) => row.reduce((s, a, k) => s + a * B[k][j], 0)));
const transpose = (A) => A[0].map((_, j) => A.map((row) => row[j]));

// Inverse by Gauss-Jordan elimination with partial pivoting; null when a pivot is at most tol * max|A|.
// With tol = 2 eps a refused Phi has ||Phi||_F ||Phi^-1||_F >= 1 / (2 eps): no float64 answer there
// carries a correct digit, and the certification judges none there; an exactly singular Phi has a zero pivot.
function invert(A, tol) {
  const n = A.length;
  const M = A.map((r) => r.slice());
  const X = eye(n);
  const big = Math.max(...A.flat().map(Math.abs));
  for (let c = 0; c < n; c++) {
    let p = c;
    for (let r = c + 1; r < n; r++) if (Math.abs(M[r][c]) > Math.abs(M[p][c])) p = r;
    if (!(Math.abs(M[p][c]) > tol * big)) return null;
    [M[c], M[p]] = [M[p], M[c]];
    [X[c], X[p]] = [X[p], X[c]];
    for (let r = 0; r < n; r++) {
      if (r === c) continue;
      const m = M[r][c] / M[c][c];
      if (m === 0) continue;
      for (let j = 0; j < n; j++) { M[r][j] -= m * M[c][j]; X[r][j] -= m * X[c][j]; }
    }
  }
  return X.map((row, r) => row.map((v) => v / M[r][r]));
}

// exp(M): scale so that ||M / 2^s||_1 <= 1/2, Taylor to degree 20 (remainder < 1e-25), square s times.
function expm(M) {
  const n = M.length;
  let norm = 0;
  for (let j = 0; j < n; j++) norm = Math.max(norm, M.reduce((s, row) => s + Math.abs(row[j]), 0));
  const s = norm > 0.5 ? Math.ceil(Math.log2(norm / 0.5)) : 0;
  const A = M.map((row) => row.map((v) => v * 2 ** -s));
  let E = eye(n);
  let term = eye(n);
  for (let k = 1; k <= 20; k++) {
    term = matmul(term, A).map((row) => row.map((v) => v / k));
    E = E.map((row, i) => row.map((v, j) => v + term[i][j]));
  }
  for (let k = 0; k < s; k++) E = matmul(E, E);
  return E;
}

class Refusal extends Error {}

function checkShapes({ f, theta, upsilon, x, pi }) {
  const n = Array.isArray(f) ? f.length : 0;
  const isVec = (v) => Array.isArray(v) && v.length === n && v.every((a) => typeof a === "number");
  const isMat = (m) => Array.isArray(m) && m.length === n && m.every(isVec);
  if (!(n >= 1 && f.every(isMat) && isMat(theta) && isMat(upsilon) && isVec(x) && isVec(pi))) {
    throw new Error("bad request: args f (n x n x n), theta, upsilon (n x n), x, pi (n) must be numbers of matching shapes");
  }
  return n;
}

function poissonTensor(args) {
  const n = checkShapes(args);
  const { f, theta, upsilon, x, pi } = args;
  // the frame: phi1(-ad_x) from exp([[-ad_x, 1], [0, 0]]), then L(g, e) = phi1(-ad_x)^-1
  const ad = zeros(n, n);
  for (let m = 0; m < n; m++) for (let b = 0; b < n; b++) for (let a = 0; a < n; a++) ad[m][b] += x[a] * f[m][a][b];
  const big = zeros(2 * n, 2 * n);
  for (let i = 0; i < n; i++) for (let j = 0; j < n; j++) { big[i][j] = -ad[i][j]; big[i][n + j] = i === j ? 1 : 0; }
  const E = expm(big);
  const phi1 = E.slice(0, n).map((row) => row.slice(n));
  const L = invert(phi1, 2 * EPS);
  if (L === null) throw new Refusal("ValueError: x is outside the chart of exponential coordinates (phi1(-ad_x) is singular)");
  // S and Phi = 1 + S Upsilon; the degenerate set is where Phi is singular
  const S = zeros(n, n);
  for (let a = 0; a < n; a++) for (let b = 0; b < n; b++) {
    let s = -theta[a][b];
    for (let m = 0; m < n; m++) s += pi[m] * f[m][a][b];
    S[a][b] = s;
  }
  const Phi = matmul(S, upsilon).map((row, i) => row.map((v, j) => v + (i === j ? 1 : 0)));
  const PhiInv = invert(Phi, 2 * EPS);
  if (PhiInv === null) {
    throw new Refusal("ValueError: degenerate point: Phi = 1 + S Upsilon is singular to working precision (Delta = 0)");
  }
  const PsiInv = transpose(PhiInv);
  const Lt = transpose(L);
  const xx = matmul(matmul(L, matmul(upsilon, PhiInv)), Lt).map((row) => row.map((v) => -v)); // L (-U Phi^-1) L^T
  const xp = matmul(L, PsiInv); // L Psi^-1
  const px = matmul(PhiInv, Lt).map((row) => row.map((v) => -v)); // -Phi^-1 L^T
  const pp = matmul(S, PsiInv).map((row) => row.map((v) => -v)); // -S Psi^-1
  const P = [...xx.map((row, i) => [...row, ...xp[i]]), ...px.map((row, i) => [...row, ...pp[i]])];
  return P.map((row, i) => row.map((v, j) => {
    const w = 0.5 * (v - P[j][i]);
    return Number.isFinite(w) ? w : null; // JSON has no NaN: null stands for a non-finite entry
  }));
}

const CAPABILITIES = {
  protocol_version: "1.0", name: "tstarg example client (JavaScript)", version: "1.0",
  methods: ["poisson_tensor"], algebras: "all", theta: true, upsilon: true, batched: false,
};

function answer(req) {
  if (req.method === "capabilities") return { id: req.id, result: CAPABILITIES };
  if (req.method === "poisson_tensor") return { id: req.id, result: poissonTensor(req.args) };
  return { id: req.id, error: `unknown method ${req.method}` };
}

const rl = createInterface({ input: process.stdin, crlfDelay: Infinity });
rl.on("line", (line) => {
  let req = {};
  let reply;
  try {
    req = JSON.parse(line);
    reply = answer(req);
  } catch (err) {
    reply = { id: req.id ?? null, error: err instanceof Refusal ? err.message : `error: ${err.message}` };
  }
  process.stdout.write(JSON.stringify(reply) + "\n");
});

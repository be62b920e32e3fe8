/*
 * An implementation of the tstarg JSON-lines protocol 1.0 in C99 (poisson_tensor, any Lie algebra).
 *
 * Build and certify:
 *     gcc -O2 -std=c99 -o tstarg_client examples/c/tstarg_client.c -lm
 *     tstarg certify --cmd "./tstarg_client" --max-examples 10
 *
 * One request per line on stdin ({"id", "method", "args"}), one reply per line on stdout
 * ({"id", "result"} or {"id", "error"}); schema: reports/schema/ (request and reply .schema.json).
 *
 * The mathematics (CONVENTIONS.md of tstarg; the paper's equation vier9):
 *   ad_x[m][b] = x^a f^m_ab,      L(g, e) = phi1(-ad_x)^-1,   phi1(A) = (e^A - 1) / A,
 *   S_ab = pi_m f^m_ab - Theta_ab, Phi = 1 + S Upsilon,        Psi = 1 + Upsilon S = Phi^T,
 *   -W^-1 = [[-Upsilon Phi^-1, Psi^-1], [-Phi^-1, -S Psi^-1]]  (vier9),
 *   P = T (-W^-1) T^T with T = diag(L(g, e), 1),               P[i][j] = {z_i, z_j}, z = (x, pi).
 * phi1(A) is the top-right block of exp([[A, 1], [0, 0]]) (Van Loan), computed by scaling and
 * squaring with a Taylor polynomial. The exact P is antisymmetric; rounding makes the computed
 * one asymmetric by about eps cond(Phi) max|P|, so we return (P - P^T) / 2, which is no farther
 * from the exact P. A point where Phi is singular to working precision (the degenerate set
 * Delta = det Phi = 0, vier7) is refused with "ValueError: ...", as the protocol asks.
 */
#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ a small JSON reader */
typedef enum { J_NULL, J_BOOL, J_NUM, J_STR, J_ARR, J_OBJ } jtype;
typedef struct jval {
    jtype type;
    double num;
    char *str;            /* J_STR: the string; J_NUM: the literal as written */
    struct jval **items;  /* J_ARR, J_OBJ (values) */
    char **keys;          /* J_OBJ */
    int len;
} jval;

static const char *jp;

static void jskip(void) { while (*jp && isspace((unsigned char)*jp)) jp++; }

static void jfree(jval *v) {
    if (!v) return;
    for (int i = 0; i < v->len; i++) {
        jfree(v->items[i]);
        if (v->keys) free(v->keys[i]);
    }
    free(v->items);
    free(v->keys);
    free(v->str);
    free(v);
}

static jval *jnew(jtype t) {
    jval *v = calloc(1, sizeof(jval));
    v->type = t;
    return v;
}

static char *jstring(void) { /* at the opening quote; escapes kept only as far as we need them */
    jp++;
    size_t cap = 16, n = 0;
    char *s = malloc(cap);
    while (*jp && *jp != '"') {
        char c = *jp++;
        if (c == '\\' && *jp) {
            c = *jp++;
            if (c == 'n') c = '\n';
            else if (c == 't') c = '\t';
            else if (c == 'u') { jp += 4; c = '?'; }
        }
        if (n + 2 > cap) s = realloc(s, cap *= 2);
        s[n++] = c;
    }
    s[n] = 0;
    if (*jp != '"') { free(s); return NULL; }
    jp++;
    return s;
}

static jval *jparse(void) {
    jskip();
    jval *v;
    if (*jp == '{' || *jp == '[') {
        int obj = *jp == '{';
        char close = obj ? '}' : ']';
        v = jnew(obj ? J_OBJ : J_ARR);
        int cap = 4;
        v->items = malloc(cap * sizeof(jval *));
        if (obj) v->keys = malloc(cap * sizeof(char *));
        jp++;
        jskip();
        if (*jp == close) { jp++; return v; }
        for (;;) {
            char *key = NULL;
            jskip();
            if (obj) {
                if (*jp != '"' || !(key = jstring())) { jfree(v); return NULL; }
                jskip();
                if (*jp++ != ':') { free(key); jfree(v); return NULL; }
            }
            jval *item = jparse();
            if (!item) { free(key); jfree(v); return NULL; }
            if (v->len == cap) {
                cap *= 2;
                v->items = realloc(v->items, cap * sizeof(jval *));
                if (obj) v->keys = realloc(v->keys, cap * sizeof(char *));
            }
            if (obj) v->keys[v->len] = key;
            v->items[v->len++] = item;
            jskip();
            if (*jp == ',') { jp++; continue; }
            if (*jp == close) { jp++; return v; }
            jfree(v);
            return NULL;
        }
    }
    if (*jp == '"') {
        v = jnew(J_STR);
        if (!(v->str = jstring())) { jfree(v); return NULL; }
        return v;
    }
    if (!strncmp(jp, "null", 4)) { jp += 4; return jnew(J_NULL); }
    if (!strncmp(jp, "true", 4)) { jp += 4; v = jnew(J_BOOL); v->num = 1; return v; }
    if (!strncmp(jp, "false", 5)) { jp += 5; return jnew(J_BOOL); }
    char *end;
    double d = strtod(jp, &end);
    if (end == jp) return NULL;
    v = jnew(J_NUM);
    v->num = d;
    v->str = malloc(end - jp + 1);
    memcpy(v->str, jp, end - jp);
    v->str[end - jp] = 0;
    jp = end;
    return v;
}

static jval *jget(const jval *obj, const char *key) {
    if (!obj || obj->type != J_OBJ) return NULL;
    for (int i = 0; i < obj->len; i++)
        if (!strcmp(obj->keys[i], key)) return obj->items[i];
    return NULL;
}

/* ------------------------------------------------------------------ replies */
static void print_id(const jval *id) {
    if (id && id->type == J_NUM) printf("%s", id->str);
    else if (id && id->type == J_STR) printf("\"%s\"", id->str);
    else printf("null");
}

static void reply_error(const jval *id, const char *msg) {
    printf("{\"id\": ");
    print_id(id);
    printf(", \"error\": \"");
    for (const char *c = msg; *c; c++) putchar(*c == '"' || *c == '\\' ? '\'' : *c);
    printf("\"}\n");
    fflush(stdout);
}

/* ------------------------------------------------------------------ linear algebra (row-major) */
#define AT(M, n, i, j) ((M)[(size_t)(i) * (n) + (j)])

static void matmul(int n, const double *A, const double *B, double *C) { /* C = A B */
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double s = 0;
            for (int k = 0; k < n; k++) s += AT(A, n, i, k) * AT(B, n, k, j);
            AT(C, n, i, j) = s;
        }
}

/* Inverse by Gaussian elimination with partial pivoting. Returns 0 when a pivot is at most
 * tol * max|A| (singular to working precision). With tol = 2 eps a refused Phi has
 * ||Phi||_F ||Phi^-1||_F >= 1 / (2 eps): no float64 answer there carries a correct digit, and the
 * certification judges no answer there; an exactly singular Phi has a zero pivot. */
static int invert(int n, const double *A, double *Ainv, double tol) {
    double *M = malloc(sizeof(double) * n * n), big = 0;
    memcpy(M, A, sizeof(double) * n * n);
    for (int i = 0; i < n * n; i++) big = fmax(big, fabs(A[i]));
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) AT(Ainv, n, i, j) = i == j;
    for (int c = 0; c < n; c++) {
        int p = c;
        for (int r = c + 1; r < n; r++)
            if (fabs(AT(M, n, r, c)) > fabs(AT(M, n, p, c))) p = r;
        if (!(fabs(AT(M, n, p, c)) > tol * big)) { free(M); return 0; }
        for (int j = 0; j < n; j++) {
            double t = AT(M, n, c, j); AT(M, n, c, j) = AT(M, n, p, j); AT(M, n, p, j) = t;
            t = AT(Ainv, n, c, j); AT(Ainv, n, c, j) = AT(Ainv, n, p, j); AT(Ainv, n, p, j) = t;
        }
        for (int r = 0; r < n; r++) {
            if (r == c) continue;
            double m = AT(M, n, r, c) / AT(M, n, c, c);
            if (m == 0) continue;
            for (int j = 0; j < n; j++) {
                AT(M, n, r, j) -= m * AT(M, n, c, j);
                AT(Ainv, n, r, j) -= m * AT(Ainv, n, c, j);
            }
        }
    }
    for (int r = 0; r < n; r++) {
        double d = AT(M, n, r, r);
        for (int j = 0; j < n; j++) AT(Ainv, n, r, j) /= d;
    }
    free(M);
    return 1;
}

/* exp(M) by scaling and squaring: ||M / 2^s||_1 <= 1/2, Taylor to degree 20 (remainder < 1e-25). */
static void expm(int n, const double *M, double *E) {
    double norm = 0;
    for (int j = 0; j < n; j++) {
        double s = 0;
        for (int i = 0; i < n; i++) s += fabs(AT(M, n, i, j));
        norm = fmax(norm, s);
    }
    int s = norm > 0.5 ? (int)ceil(log2(norm / 0.5)) : 0;
    double scale = ldexp(1.0, -s);
    double *A = malloc(sizeof(double) * n * n), *term = malloc(sizeof(double) * n * n),
           *tmp = malloc(sizeof(double) * n * n);
    for (int i = 0; i < n * n; i++) A[i] = M[i] * scale;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) AT(E, n, i, j) = AT(term, n, i, j) = i == j;
    for (int k = 1; k <= 20; k++) {
        matmul(n, term, A, tmp);
        for (int i = 0; i < n * n; i++) { term[i] = tmp[i] / k; E[i] += term[i]; }
    }
    for (int k = 0; k < s; k++) {
        matmul(n, E, E, tmp);
        memcpy(E, tmp, sizeof(double) * n * n);
    }
    free(A); free(term); free(tmp);
}

/* ------------------------------------------------------------------ reading arguments */
static int read_vec(const jval *v, int n, double *out) {
    if (!v || v->type != J_ARR || v->len != n) return 0;
    for (int i = 0; i < n; i++) {
        if (v->items[i]->type != J_NUM) return 0;
        out[i] = v->items[i]->num;
    }
    return 1;
}

static int read_mat(const jval *v, int n, double *out) {
    if (!v || v->type != J_ARR || v->len != n) return 0;
    for (int i = 0; i < n; i++)
        if (!read_vec(v->items[i], n, out + (size_t)i * n)) return 0;
    return 1;
}

/* ------------------------------------------------------------------ the protocol method */
static void poisson_tensor(const jval *id, const jval *args) {
    const jval *jf = jget(args, "f");
    if (!jf || jf->type != J_ARR || jf->len < 1) { reply_error(id, "bad request: args.f must be an n x n x n array"); return; }
    int n = jf->len, N = 2 * n;
    double *f = malloc(sizeof(double) * n * n * n), *theta = malloc(sizeof(double) * n * n),
           *ups = malloc(sizeof(double) * n * n), *x = malloc(sizeof(double) * n), *pi = malloc(sizeof(double) * n);
    double *ad = calloc((size_t)n * n, sizeof(double)), *big = calloc((size_t)N * N, sizeof(double)),
           *ebig = malloc(sizeof(double) * N * N), *phi1 = malloc(sizeof(double) * n * n),
           *L = malloc(sizeof(double) * n * n), *S = malloc(sizeof(double) * n * n), *Phi = malloc(sizeof(double) * n * n),
           *Phinv = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n),
           *C = malloc(sizeof(double) * n * n), *P = malloc(sizeof(double) * N * N);
    int ok = 1;
    for (int m = 0; m < n && ok; m++) ok = read_mat(jf->items[m], n, f + (size_t)m * n * n);
    if (!ok || !read_mat(jget(args, "theta"), n, theta) || !read_mat(jget(args, "upsilon"), n, ups) ||
        !read_vec(jget(args, "x"), n, x) || !read_vec(jget(args, "pi"), n, pi)) {
        reply_error(id, "bad request: args f (n x n x n), theta, upsilon (n x n), x, pi (n) must be numbers of matching shapes");
        goto done;
    }
#define F(m, a, b) f[((size_t)(m) * n + (a)) * n + (b)]
    /* the frame: phi1(-ad_x) from exp([[-ad_x, 1], [0, 0]]), then L(g, e) = phi1(-ad_x)^-1 */
    for (int m = 0; m < n; m++)
        for (int b = 0; b < n; b++)
            for (int a = 0; a < n; a++) AT(ad, n, m, b) += x[a] * F(m, a, b);
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            AT(big, N, i, j) = -AT(ad, n, i, j);
            AT(big, N, i, n + j) = i == j;
        }
    expm(N, big, ebig);
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) AT(phi1, n, i, j) = AT(ebig, N, i, n + j);
    if (!invert(n, phi1, L, 2 * DBL_EPSILON)) {
        reply_error(id, "ValueError: x is outside the chart of exponential coordinates (phi1(-ad_x) is singular)");
        goto done;
    }
    /* S, Phi = 1 + S Upsilon; the degenerate set is where Phi is singular */
    for (int a = 0; a < n; a++)
        for (int b = 0; b < n; b++) {
            double s = -AT(theta, n, a, b);
            for (int m = 0; m < n; m++) s += pi[m] * F(m, a, b);
            AT(S, n, a, b) = s;
        }
    matmul(n, S, ups, Phi);
    for (int i = 0; i < n; i++) AT(Phi, n, i, i) += 1;
    if (!invert(n, Phi, Phinv, 2 * DBL_EPSILON)) {
        reply_error(id, "ValueError: degenerate point: Phi = 1 + S Upsilon is singular to working precision (Delta = 0)");
        goto done;
    }
    /* P_xx = L (-Upsilon Phi^-1) L^T,  P_xpi = L Psi^-1,  P_pix = -Phi^-1 L^T,  P_pipi = -S Psi^-1 */
    matmul(n, ups, Phinv, B);
    matmul(n, L, B, C);
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double s = 0;
            for (int k = 0; k < n; k++) s += AT(C, n, i, k) * AT(L, n, j, k);
            AT(P, N, i, j) = -s;
        }
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double xp = 0, px = 0, pp = 0;
            for (int k = 0; k < n; k++) {
                xp += AT(L, n, i, k) * AT(Phinv, n, j, k);      /* L Psi^-1, Psi^-1 = Phi^-T */
                px -= AT(Phinv, n, i, k) * AT(L, n, j, k);      /* -Phi^-1 L^T */
                pp -= AT(S, n, i, k) * AT(Phinv, n, j, k);      /* -S Psi^-1 */
            }
            AT(P, N, i, n + j) = xp;
            AT(P, N, n + i, j) = px;
            AT(P, N, n + i, n + j) = pp;
        }
#undef F
    printf("{\"id\": ");
    print_id(id);
    printf(", \"result\": [");
    for (int i = 0; i < N; i++) {
        printf(i ? ", [" : "[");
        for (int j = 0; j < N; j++) {
            double v = 0.5 * (AT(P, N, i, j) - AT(P, N, j, i));
            if (j) printf(", ");
            if (isfinite(v)) printf("%.17g", v);
            else printf("null");
        }
        printf("]");
    }
    printf("]}\n");
    fflush(stdout);
done:
    free(f); free(theta); free(ups); free(x); free(pi); free(ad); free(big); free(ebig); free(phi1);
    free(L); free(S); free(Phi); free(Phinv); free(B); free(C); free(P);
}

int main(void) {
    size_t cap = 1 << 16;
    char *line = malloc(cap);
    for (;;) { /* read one line of any length */
        size_t n = 0;
        int c;
        while ((c = getchar()) != EOF && c != '\n') {
            if (n + 2 > cap) line = realloc(line, cap *= 2);
            line[n++] = (char)c;
        }
        if (c == EOF && n == 0) break;
        line[n] = 0;
        jp = line;
        jval *req = jparse();
        const jval *id = jget(req, "id"), *method = jget(req, "method"), *args = jget(req, "args");
        if (!req || !method || method->type != J_STR || !args) {
            reply_error(id, "bad request: expected {\"id\", \"method\", \"args\"}");
        } else if (!strcmp(method->str, "capabilities")) {
            printf("{\"id\": ");
            print_id(id);
            printf(", \"result\": {\"protocol_version\": \"1.0\", \"name\": \"tstarg example client (C)\", "
                   "\"version\": \"1.0\", \"methods\": [\"poisson_tensor\"], \"algebras\": \"all\", "
                   "\"theta\": true, \"upsilon\": true, \"batched\": false}}\n");
            fflush(stdout);
        } else if (!strcmp(method->str, "poisson_tensor")) {
            poisson_tensor(id, args);
        } else {
            char msg[200];
            snprintf(msg, sizeof msg, "unknown method %.100s", method->str);
            reply_error(id, msg);
        }
        jfree(req);
    }
    free(line);
    return 0;
}

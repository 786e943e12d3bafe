/* An independent, event-driven CVODE implementation of the capsule model (Coulomb or viscous
 * friction, one-sided contact spring, harmonic drive, position feedback k_p |x2 - x1|), for
 * side-by-side runs with `capsule simulate --json`: the compiled counterpart of
 * bench/scipy_reference.py. It shares no code with capsule, so agreement is a check of both.
 *
 * What a user would write with SUNDIALS: CVODE (Adams-Moulton with fixed-point iteration, or BDF
 * with Newton and a dense solver) at rtol 1e-13, its rootfinding locating every switch (contact
 * on and off, the kink of |x2 - x1|, break-away, slip end), the switching rule applied at the
 * root and the integrator restarted there (CVodeReInit: the right-hand side is discontinuous).
 * The model is paper eq. 1-4 as DESIGN.md writes it, non-dimensional:
 *
 *   z = x1 - x2, f = z + 2 xi (y1 - y2) + [contact] beta (z - delta)  (the capsule's pull)
 *   x1' = y1, y1' = alpha cos(omega t) + k_p |z| - f
 *   stuck (y2 = 0) while |f| <= 1; slipping in direction d: x2' = y2, gamma y2' = f - d - mu_v y2
 *   at a slip's end (y2 = 0) stuck if |f| <= 1, else slipping in f's direction (a reversal)
 *   the actuator's work on the mass W' = f_a y1 (for the efficiency, eq. 4)
 *
 * Build and run (Debian: apt-get install libsundials-dev):
 *
 *   cc -O2 -o target/cvode_reference bench/cvode_reference.c \
 *      -lsundials_cvode -lsundials_nvecserial -lm
 *   target/cvode_reference                      # section-5 control point, as capsule's default
 *   target/cvode_reference --kp 0.1 --method bdf --rtol 1e-13
 *
 * Prints one JSON object: the fields of `capsule simulate --json` it computes (progression,
 * period, impacts, backward slips, efficiency, work per period, Poincare points, final state)
 * and CVODE's work counters. Not part of the test command (needs SUNDIALS).
 */
#include <cvode/cvode.h>
#include <math.h>
#include <nvector/nvector_serial.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>
#include <time.h>

enum { X1, Y1, X2, Y2, W, NEQ };
enum { G_CONTACT, G_KINK, G_BREAK_OR_END, G_BREAK_DOWN, NG };
#define MAX_PERIOD 64
#define PERIOD_TOL 1e-6

typedef struct {
  double gamma, beta, delta, xi, mu_v, alpha, omega, kp;
  int contact; /* the secondary spring touches (z >= delta) */
  int sigma;   /* sign of z in the feedback k_p sigma z = k_p |z| */
  int phase;   /* 0 stuck, +1 / -1 slipping that way */
} Model;

/* The force the capsule's spring, damper and contact spring exert on the mass, as a pull back. */
static double pull(const Model *m, const double *s, int contact) {
  double z = s[X1] - s[X2];
  double f = z + 2.0 * m->xi * (s[Y1] - s[Y2]);
  if (contact) f += m->beta * (z - m->delta);
  return f;
}

static int rhs(sunrealtype t, N_Vector yv, N_Vector dv, void *data) {
  const Model *m = data;
  const double *s = N_VGetArrayPointer(yv);
  double *d = N_VGetArrayPointer(dv);
  double z = s[X1] - s[X2];
  double fa = m->alpha * cos(m->omega * t) + m->kp * m->sigma * z;
  double f = pull(m, s, m->contact);
  d[X1] = s[Y1];
  d[Y1] = fa - f;
  if (m->phase == 0) {
    d[X2] = 0.0;
    d[Y2] = 0.0;
  } else {
    d[X2] = s[Y2];
    d[Y2] = (f - m->phase - m->mu_v * s[Y2]) / m->gamma;
  }
  d[W] = fa * s[Y1];
  return 0;
}

/* Every switching function rises through zero at its event (CVodeSetRootDirection +1); one that
 * does not apply in the current mode is held at -1. */
static int roots(sunrealtype t, N_Vector yv, sunrealtype *g, void *data) {
  (void)t;
  const Model *m = data;
  const double *s = N_VGetArrayPointer(yv);
  double z = s[X1] - s[X2];
  g[G_CONTACT] = m->beta > 0.0 ? (m->contact ? m->delta - z : z - m->delta) : -1.0;
  g[G_KINK] = m->kp != 0.0 ? -m->sigma * z : -1.0;
  if (m->phase == 0) {
    double f = pull(m, s, m->contact);
    g[G_BREAK_OR_END] = f - 1.0;
    g[G_BREAK_DOWN] = -f - 1.0;
  } else {
    g[G_BREAK_OR_END] = -m->phase * s[Y2];
    g[G_BREAK_DOWN] = -1.0;
  }
  return 0;
}

/* CVODE's counters since the last (re)start; CVodeReInit zeroes them. */
typedef struct {
  long steps, rhs_evals, root_evals;
} Work;

static void count(void *mem, Work *w) {
  long v = 0;
  CVodeGetNumSteps(mem, &v);
  w->steps += v;
  CVodeGetNumRhsEvals(mem, &v);
  w->rhs_evals += v;
  CVodeGetNumGEvals(mem, &v);
  w->root_evals += v;
}

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static void die(const char *what, int flag) {
  fprintf(stderr, "cvode_reference: %s failed (flag %d)\n", what, flag);
  exit(1);
}

static double parse_num(const char *name, const char *text) {
  char *end;
  double v = strtod(text, &end);
  if (*text == '\0' || *end != '\0' || !isfinite(v)) {
    fprintf(stderr, "cvode_reference: %s: `%s` is not a finite number\n", name, text);
    exit(2);
  }
  return v;
}

/* Smallest k <= MAX_PERIOD with |P[n] - P[n-k]| <= tol for every n >= k (max norm), or 0. */
static int detect_period(double (*p)[3], int n) {
  for (int k = 1; k <= MAX_PERIOD && k < n; k++) {
    int ok = 1;
    for (int i = k; i < n && ok; i++)
      for (int c = 0; c < 3; c++)
        if (fabs(p[i][c] - p[i - k][c]) > PERIOD_TOL) ok = 0;
    if (ok) return k;
  }
  return 0;
}

int main(int argc, char **argv) {
  /* the section-5 control point (scenes/control_point.toml) */
  Model m = {.gamma = 0.235, .beta = 3.05, .delta = 0.02, .xi = 0.05, .mu_v = 0.0,
             .alpha = 1.6, .omega = 1.1, .kp = 0.0};
  double rtol = 1e-13, atol = 1e-15;
  int periods = 300, transient = 200, bdf = 0;
  struct { const char *flag; double *to; } nums[] = {
      {"--gamma", &m.gamma}, {"--beta", &m.beta}, {"--delta", &m.delta}, {"--xi", &m.xi},
      {"--mu-v", &m.mu_v},   {"--alpha", &m.alpha}, {"--omega", &m.omega}, {"--kp", &m.kp},
      {"--rtol", &rtol},     {"--atol", &atol}};
  for (int i = 1; i < argc; i++) {
    int known = 0;
    for (size_t k = 0; k < sizeof nums / sizeof nums[0]; k++)
      if (!strcmp(argv[i], nums[k].flag) && i + 1 < argc) {
        *nums[k].to = parse_num(argv[i], argv[i + 1]);
        i++;
        known = 1;
      }
    if (known) continue;
    if (!strcmp(argv[i], "--periods") && i + 1 < argc) {
      periods = (int)parse_num(argv[i], argv[i + 1]);
      i++;
    } else if (!strcmp(argv[i], "--transient") && i + 1 < argc) {
      transient = (int)parse_num(argv[i], argv[i + 1]);
      i++;
    } else if (!strcmp(argv[i], "--method") && i + 1 < argc) {
      i++;
      if (!strcmp(argv[i], "bdf")) bdf = 1;
      else if (strcmp(argv[i], "adams")) {
        fprintf(stderr, "cvode_reference: --method: `%s` is not adams or bdf\n", argv[i]);
        return 2;
      }
    } else {
      fprintf(stderr, "cvode_reference: unknown argument `%s` (flags: --gamma --beta --delta "
                      "--xi --mu-v --alpha --omega --kp --rtol --atol --periods --transient "
                      "--method adams|bdf)\n", argv[i]);
      return 2;
    }
  }
  if (m.gamma <= 0.0 || m.omega <= 0.0 || m.beta < 0.0 || m.delta < 0.0 || m.mu_v < 0.0 ||
      rtol <= 0.0 || atol <= 0.0 || periods < 1 || transient < 0 || transient >= periods) {
    fprintf(stderr, "cvode_reference: need gamma, omega, rtol, atol > 0; beta, delta, mu_v >= 0;"
                    " 0 <= transient < periods\n");
    return 2;
  }
  double t0 = now();

  SUNContext ctx;
  int flag = SUNContext_Create(NULL, &ctx);
  if (flag) die("SUNContext_Create", flag);
  N_Vector y = N_VNew_Serial(NEQ, ctx);
  double *s = N_VGetArrayPointer(y);
  for (int i = 0; i < NEQ; i++) s[i] = 0.0;
  /* from rest: stuck (|f| = 0 <= 1), out of contact, and the mass moves to z > 0 first */
  m.contact = 0;
  m.sigma = 1;
  m.phase = 0;
  double t = 0.0;

  void *mem = CVodeCreate(bdf ? CV_BDF : CV_ADAMS, ctx);
  if (!mem) die("CVodeCreate", 0);
  if ((flag = CVodeInit(mem, rhs, t, y))) die("CVodeInit", flag);
  if ((flag = CVodeSStolerances(mem, rtol, atol))) die("CVodeSStolerances", flag);
  if ((flag = CVodeSetUserData(mem, &m))) die("CVodeSetUserData", flag);
  if ((flag = CVodeSetMaxNumSteps(mem, 10000000))) die("CVodeSetMaxNumSteps", flag);
  SUNMatrix a = NULL;
  SUNLinearSolver ls = NULL;
  SUNNonlinearSolver nls = NULL;
  if (bdf) {
    a = SUNDenseMatrix(NEQ, NEQ, ctx);
    ls = SUNLinSol_Dense(y, a, ctx);
    if ((flag = CVodeSetLinearSolver(mem, ls, a))) die("CVodeSetLinearSolver", flag);
  } else {
    nls = SUNNonlinSol_FixedPoint(y, 0, ctx);
    if ((flag = CVodeSetNonlinearSolver(mem, nls))) die("CVodeSetNonlinearSolver", flag);
  }
  if ((flag = CVodeRootInit(mem, NG, roots))) die("CVodeRootInit", flag);
  int dirs[NG] = {1, 1, 1, 1};
  if ((flag = CVodeSetRootDirection(mem, dirs))) die("CVodeSetRootDirection", flag);

  double period = 2.0 * M_PI / m.omega;
  int measured = periods - transient;
  double (*poincare)[3] = calloc((size_t)measured, sizeof *poincare);
  if (!poincare) die("calloc", 0);
  long impacts = 0, backward = 0, events = 0;
  Work work = {0, 0, 0};
  double x2_start = 0.0, w_start = 0.0;
  for (int n = 0; n < periods; n++) {
    int measuring = n >= transient;
    if (n == transient) {
      x2_start = s[X2];
      w_start = s[W];
    }
    double t_end = (n + 1) * period;
    if ((flag = CVodeSetStopTime(mem, t_end))) die("CVodeSetStopTime", flag);
    for (;;) {
      flag = CVode(mem, t_end, y, &t, CV_NORMAL);
      if (flag == CV_TSTOP_RETURN || (flag == CV_SUCCESS && t >= t_end)) break;
      if (flag != CV_ROOT_RETURN) die("CVode", flag);
      int found[NG];
      if ((flag = CVodeGetRootInfo(mem, found))) die("CVodeGetRootInfo", flag);
      events++;
      if (found[G_CONTACT]) {
        m.contact = !m.contact;
        if (m.contact && measuring) impacts++;
      }
      if (found[G_KINK]) m.sigma = -m.sigma;
      if (m.phase == 0 && (found[G_BREAK_OR_END] || found[G_BREAK_DOWN])) {
        m.phase = found[G_BREAK_OR_END] ? 1 : -1;
        s[Y2] = 0.0;
        if (m.phase < 0 && measuring) backward++;
      } else if (m.phase != 0 && found[G_BREAK_OR_END]) {
        s[Y2] = 0.0;
        double f = pull(&m, s, m.contact);
        m.phase = fabs(f) <= 1.0 ? 0 : (f > 0.0 ? 1 : -1);
        if (m.phase < 0 && measuring) backward++;
      }
      count(mem, &work);
      if ((flag = CVodeReInit(mem, t, y))) die("CVodeReInit", flag);
    }
    if (measuring) {
      double *p = poincare[n - transient];
      p[0] = s[X1] - s[X2];
      p[1] = s[Y1] - s[Y2];
      p[2] = s[Y1];
    }
  }
  double progression = s[X2] - x2_start, actuator_work = s[W] - w_start;
  int k = detect_period(poincare, measured);
  count(mem, &work);
  double wall = now() - t0;

  printf("{\n  \"impl\": \"CVODE %s\",\n  \"rtol\": %g,\n  \"atol\": %g,\n",
         bdf ? "BDF (Newton, dense)" : "Adams (fixed point)", rtol, atol);
  printf("  \"avg_progression\": %.17g,\n", progression / measured);
  if (k) printf("  \"period\": %d,\n", k);
  else printf("  \"period\": null,\n");
  printf("  \"impacts_per_period\": %.17g,\n", (double)impacts / measured);
  printf("  \"backward_slips_per_period\": %.17g,\n", (double)backward / measured);
  printf("  \"efficiency\": %.17g,\n", progression / actuator_work);
  printf("  \"work_per_period\": %.17g,\n", actuator_work / measured);
  printf("  \"poincare\": [");
  for (int i = 0; i < measured; i++)
    printf("%s[%.17g, %.17g, %.17g]", i ? ", " : "", poincare[i][0], poincare[i][1],
           poincare[i][2]);
  printf("],\n  \"final_state\": {\"x1\": %.17g, \"y1\": %.17g, \"x2\": %.17g, \"y2\": %.17g},\n",
         s[X1], s[Y1], s[X2], s[Y2]);
  printf("  \"measured_periods\": %d,\n", measured);
  printf("  \"work\": {\"steps\": %ld, \"rhs_evals\": %ld, \"root_evals\": %ld, \"events\": %ld},\n",
         work.steps, work.rhs_evals, work.root_evals, events);
  printf("  \"wall_time_s\": %.9f\n}\n", wall);

  free(poincare);
  if (nls) SUNNonlinSolFree(nls);
  if (ls) SUNLinSolFree(ls);
  if (a) SUNMatDestroy(a);
  CVodeFree(&mem);
  N_VDestroy(y);
  SUNContext_Free(&ctx);
  return 0;
}

"""The C helpers every translated module starts with: numba's semantics where C's differ.

Under numba's default error model a division by zero raises ZeroDivisionError; C cannot raise,
so the checked forms set ``zero_division`` (thread-local: kernels run side by side on threads)
and the extension function raises after the kernel returns.
"""

PRELUDE = r"""#include <stdint.h>
#include <string.h>
#include <math.h>
static _Thread_local int zero_division;
static inline double div_checked(double a, double b) { if (b == 0.0) { zero_division = 1; return 0.0; } return a / b; }
static inline int64_t wrap_i(int64_t i, int64_t n) { return i < 0 ? i + n : i; }
static inline int64_t shl_i(int64_t a, int64_t s) { return (int64_t)((uint64_t)a << s); }
static inline int64_t abs_i(int64_t a) { return a < 0 ? (int64_t)(0 - (uint64_t)a) : a; }
static inline int64_t max_i(int64_t a, int64_t b) { return b > a ? b : a; }
static inline int64_t min_i(int64_t a, int64_t b) { return b < a ? b : a; }
static inline double max_f(double a, double b) { return b > a ? b : a; }
static inline double min_f(double a, double b) { return b < a ? b : a; }
static inline _Bool max_b(_Bool a, _Bool b) { return b > a ? b : a; }
static inline _Bool min_b(_Bool a, _Bool b) { return b < a ? b : a; }
static inline int64_t floordiv_i(int64_t a, int64_t b) {
    if (b == 0) return 0;
    if (b == -1) return (int64_t)(0 - (uint64_t)a);
    int64_t q = a / b; if ((a % b != 0) && ((a < 0) != (b < 0))) q -= 1; return q; }
static inline int64_t mod_i(int64_t a, int64_t b) {
    if (b == 0 || b == -1) return 0;
    int64_t r = a % b; if (r != 0 && ((r < 0) != (b < 0))) r += b; return r; }
static inline double divmod_f(double vx, double wx, double *mod_out) {
    /* numba's real_divmod (CPython's float_divmod): its comparisons ordered or not as there */
    double mod = fmod(vx, wx), div = (vx - mod) / wx, floordiv;
    if (mod != 0.0) { if ((wx < 0.0) != (mod < 0.0)) { div = div - 1.0; mod = mod + wx; } }
    else mod = (wx < 0.0) ? -0.0 : 0.0;
    if (div != 0.0 && div == div) { floordiv = floor(div); if (div - floordiv > 0.5) floordiv = floordiv + 1.0; }
    else { div = div * div; floordiv = (div * vx) / wx; }
    *mod_out = mod;
    return floordiv; }
static inline double mod_f(double a, double b) {
    double m; if (b == 0.0) return fmod(a, b); divmod_f(a, b, &m); return m; }
static inline double floordiv_f(double a, double b) {
    double m; if (b == 0.0) return a / b; return divmod_f(a, b, &m); }
static inline int64_t floordiv_i_checked(int64_t a, int64_t b) {
    if (b == 0) { zero_division = 1; return 0; } return floordiv_i(a, b); }
static inline int64_t mod_i_checked(int64_t a, int64_t b) {
    if (b == 0) { zero_division = 1; return 0; } return mod_i(a, b); }
static inline double floordiv_f_checked(double a, double b) {
    if (b == 0.0) { zero_division = 1; return 0.0; } return floordiv_f(a, b); }
static inline double mod_f_checked(double a, double b) {
    if (b == 0.0) { zero_division = 1; return 0.0; } return mod_f(a, b); }
static inline double ipow_f(double a, int64_t e) {
    /* numba's integer power of a float: square and multiply; above 2**16 math.pow; a negative
       exponent inverts, and inverting zero raises (numba compiles 1.0 / r under its default model) */
    int inv = e < 0; uint64_t n = inv ? 0 - (uint64_t)e : (uint64_t)e; double r = 1.0;
    if (n > 0x10000) return pow(a, (double)e);
    while (n) { if (n & 1) r = r * a; n >>= 1; a = a * a; }
    if (!inv) return r;
    if (r == 0.0) { zero_division = 1; return 0.0; }
    return 1.0 / r; }
static inline double pow_f(double a, double b) {
    /* an exponent of one (a Stribeck form factor of 1) returns its base: pow's result is within
       0.52 ulp of the exact one, and a base that is a double is the only double that near */
    return b == 1.0 ? a : pow(a, b); }
static inline int64_t ipow_i(int64_t a, int64_t e, int raises) {
    if (e < 0) {
        if (a == 0) { if (raises) zero_division = 1; return INT64_MIN; }
        if (a == 1) return 1;
        if (a == -1) return (e & 1) ? -1 : 1;
        return 0; }
    uint64_t r = 1, x = (uint64_t)a, n = (uint64_t)e;
    while (n) { if (n & 1) r = r * x; n >>= 1; x = x * x; }
    return (int64_t)r; }
"""

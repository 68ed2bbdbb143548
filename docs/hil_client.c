/* Example external controller for `pendc hil --serve 127.0.0.1:PORT` (protocol: docs/hil.md).
 * Energy swing-up, then LQR balance; gains from pendc.hil for models/sct_thesis_final.toml.
 * Build: gcc -O2 -o hil_client docs/hil_client.c -lm     Run: ./hil_client 127.0.0.1 5555 */
#include <arpa/inet.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <unistd.h>
static const double MGL = 0.79122, J = 0.017414, A11 = -8.78888, B1 = 2.52183, U0 = 5.264616, UC = 0.40431;
static const double K[4] = {-97.876, -49.102, -107.393, -14.222}, XC = 2.5e-6, TC = 2 * M_PI / 20000, H = 1e-3;
int main(int argc, char **argv) {
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons(argc > 2 ? atoi(argv[2]) : 5555)};
    int fd = socket(AF_INET, SOCK_STREAM, 0), balancing = 0;
    inet_pton(AF_INET, argc > 1 ? argv[1] : "127.0.0.1", &a.sin_addr);
    if (connect(fd, (struct sockaddr *)&a, sizeof a) != 0) { perror("connect"); return 1; }
    FILE *in = fdopen(fd, "r"), *out = fdopen(dup(fd), "w");
    char line[256]; long k, ex, et; double t, x, th, px = 0, pt = 0, vx = 0, vt = 0;
    while (fgets(line, sizeof line, in)) {
        if (sscanf(line, "S %ld %lf %ld %ld", &k, &t, &ex, &et) != 4) { fputs(line, stderr); continue; }
        x = ex * XC; th = et * TC;                      /* x4 counts -> m, rad (0 = hanging) */
        if (k > 0) { vx += 0.2 * ((x - px) / H - vx); vt += 0.2 * ((th - pt) / H - vt); }
        px = x; pt = th;
        double phi = remainder(th - M_PI, 2 * M_PI), u;  /* angle from upright */
        if (!balancing && fabs(phi) < 0.4 && fabs(vt) < 5) balancing = 1;
        if (balancing && fabs(phi) > 0.8) balancing = 0;
        if (balancing) {
            double du = -(K[0] * x + K[1] * vx + K[2] * phi + K[3] * vt);
            u = U0 + du + UC * tanh(du / 0.05);          /* LQR + dry-friction compensation */
        } else {
            double e = 0.5 * J * vt * vt - MGL * cos(th), s = vt * cos(th) < 0 ? -1 : 1;
            double acc = fmax(-5, fmin(5, 100 * (MGL - e) * s)) - 12 * x - 6 * vx;
            u = U0 + (acc - A11 * vx) / B1;               /* energy pumping, cart kept central */
        }
        fprintf(out, "%.4f\n", u); fflush(out);
    }
    return 0;
}

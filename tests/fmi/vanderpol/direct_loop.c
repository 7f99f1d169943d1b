/* The VanDerPol FMU's own cost per doStep, called from C without any importer (the floor under
 * `lash bench fmu`): dlopen the binary, instantiate, 5 rounds of N doStep calls, median.
 * build: cc -O2 -o direct_loop direct_loop.c -ldl;  run: ./direct_loop <unpacked>/binaries/linux64/vanderpol.so */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

typedef void *(*inst_t)(const char *, int, const char *, const char *, const void *, int, int);
typedef int (*unary_t)(void *);
typedef int (*setup_t)(void *, int, double, double, int, double);
typedef int (*step_t)(void *, double, double, int);

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc < 2) return 2;
    void *lib = dlopen(argv[1], RTLD_NOW);
    if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 1; }
    inst_t inst = (inst_t)dlsym(lib, "fmi2Instantiate");
    setup_t setup = (setup_t)dlsym(lib, "fmi2SetupExperiment");
    unary_t enter = (unary_t)dlsym(lib, "fmi2EnterInitializationMode");
    unary_t exit_ = (unary_t)dlsym(lib, "fmi2ExitInitializationMode");
    step_t step = (step_t)dlsym(lib, "fmi2DoStep");
    void *c = inst("direct", 1, "{8c4e810f-3df3-4a00-8276-176fa3c9f000}", "", NULL, 0, 0);
    if (!c) return 1;
    setup(c, 0, 0.0, 0.0, 0, 0.0);
    enter(c);
    exit_(c);
    const long n = 1000000;
    double rounds[6], t = 0.0;
    for (int r = 0; r < 6; r++) {
        struct timespec a, b;
        clock_gettime(CLOCK_MONOTONIC, &a);
        for (long k = 0; k < n; k++) {
            if (step(c, t, 0.01, 1) != 0) return 1;
            t += 0.01;
        }
        clock_gettime(CLOCK_MONOTONIC, &b);
        rounds[r] = ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / n;
    }
    qsort(rounds + 1, 5, sizeof(double), cmp);
    printf("direct C loop over fmi2DoStep: %.1f ns per step (median of 5 rounds of %ld)\n", rounds[3], n);
    return 0;
}

/* How far this host lets two threads scale on pure arithmetic, with no memory traffic: each thread
 * runs twelve independent chains of AVX multiplies and adds held in registers, which keep a
 * core's vector units busy. Two threads on two free cores take the time of one (2.0x); on two
 * hardware threads of one core, or on cores the hypervisor is sharing, they take longer. Prints,
 * per round, one thread's time, two threads' time and the scaling 2 * one / two.
 *
 *   gcc -O2 -mavx2 -pthread -o two_cores scripts/perf/two_cores.c && ./two_cores ROUNDS
 *
 * scripts/perf/two_cores.sh runs it alternately with `braille bench --streams 2`. */
#include <immintrin.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define CHAINS 12
#define ITERATIONS 60000000L

static volatile float sink;

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static void *spin(void *unused) {
    (void)unused;
    __m256 a[CHAINS];
    for (int j = 0; j < CHAINS; j++) a[j] = _mm256_set1_ps(1.0f + j * 1e-3f);
    const __m256 m = _mm256_set1_ps(0.9999999f), c = _mm256_set1_ps(1e-7f);
    for (long i = 0; i < ITERATIONS; i++)
        for (int j = 0; j < CHAINS; j++) a[j] = _mm256_add_ps(_mm256_mul_ps(a[j], m), c);
    float s = 0.0f, lanes[8];
    for (int j = 0; j < CHAINS; j++) {
        _mm256_storeu_ps(lanes, a[j]);
        s += lanes[0];
    }
    sink = s;
    return NULL;
}

int main(int argc, char **argv) {
    int rounds = argc > 1 ? atoi(argv[1]) : 5;
    for (int r = 0; r < rounds; r++) {
        double t0 = now();
        spin(NULL);
        double one = now() - t0;
        pthread_t a, b;
        t0 = now();
        pthread_create(&a, NULL, spin, NULL);
        pthread_create(&b, NULL, spin, NULL);
        pthread_join(a, NULL);
        pthread_join(b, NULL);
        double two = now() - t0;
        printf("one %.3f s, two %.3f s: scaling %.2fx\n", one, two, 2.0 * one / two);
        fflush(stdout);
    }
    return 0;
}

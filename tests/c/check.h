/*
 * What the C test programs share (tests/c/cantilever.c, tests/c/mass_spring_damper.c): a
 * check that counts its failures and prints the line of each, and the printing of
 * results as the bits of each float, which the Rust test compares with the generated
 * Rust code's.
 */
#ifndef STATEFORGE_TEST_CHECK_H
#define STATEFORGE_TEST_CHECK_H

#include <stdint.h>
#include <stdio.h>
#include <string.h>

static int failures = 0;

#define CHECK(condition)                                                              \
    do {                                                                              \
        if (!(condition)) {                                                           \
            printf("check failed: line %d: %s\n", __LINE__, #condition);             \
            failures += 1;                                                            \
        }                                                                             \
    } while (0)

/* Prints the bits of `n` floats after `name`. */
static void print_f32(const char *name, const float *values, int n) {
    int i;
    printf("%s", name);
    for (i = 0; i < n; i++) {
        uint32_t bits;
        memcpy(&bits, &values[i], sizeof bits);
        printf(" %08lx", (unsigned long)bits);
    }
    printf("\n");
}

/* Prints the bits of `n` doubles after `name`. */
static void print_f64(const char *name, const double *values, int n) {
    int i;
    printf("%s", name);
    for (i = 0; i < n; i++) {
        uint64_t bits;
        memcpy(&bits, &values[i], sizeof bits);
        printf(" %016llx", (unsigned long long)bits);
    }
    printf("\n");
}

#endif /* STATEFORGE_TEST_CHECK_H */

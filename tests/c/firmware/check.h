/* check.h: the few assertion macros the firmware unit tests use, and their case runner
   (--list, --case NAME: one ctest per case). */
#ifndef NAVKIT_TEST_CHECK_H
#define NAVKIT_TEST_CHECK_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int check_failures;

#define CHECK(cond)                                                                                                    \
    do {                                                                                                               \
        if (!(cond)) {                                                                                                 \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);                                   \
            check_failures++;                                                                                          \
        }                                                                                                              \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                                                          \
    do {                                                                                                               \
        double check_a_ = (double)(a), check_b_ = (double)(b);                                                         \
        if (!(fabs(check_a_ - check_b_) <= (double)(tol))) {                                                           \
            fprintf(stderr, "%s:%d: CHECK_NEAR failed: %s = %g, %s = %g, tol %g\n", __FILE__, __LINE__, #a, check_a_,  \
                    #b, check_b_, (double)(tol));                                                                      \
            check_failures++;                                                                                          \
        }                                                                                                              \
    } while (0)

/* check_status: the program's exit status after its cases ran: EXIT_FAILURE with the number of
   failed checks on stderr, or EXIT_SUCCESS with "ok" on stdout. */
static inline int check_status(void)
{
    if (check_failures) {
        fprintf(stderr, "%d check(s) failed\n", check_failures);
        return EXIT_FAILURE;
    }
    printf("ok\n");
    return EXIT_SUCCESS;
}

/* CHECK_DONE: ends main() of a program without a case table with check_status(). */
#define CHECK_DONE() return check_status()

/* One case of a test program: its name, as --case and --list say it, and its function. */
typedef struct {
    const char *name;
    void (*run)(void);
} check_case_t;

/* CHECK_CASE(name): the case table entry for the function test_<name>. CMake reads these
   entries from the source (navkit_fw_cases in tests/c/firmware/CMakeLists.txt) to register
   one ctest per case, so a table is written with them, one entry per case. */
#define CHECK_CASE(name)                                                                                               \
    {                                                                                                                  \
#name, test_##name                                                                                             \
    }

/* check_list: prints the names of the n cases, one a line, in table order. */
static inline void check_list(const check_case_t *cases, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) {
        printf("%s\n", cases[i].name);
    }
}

/* check_run: runs the case called name, or every case in table order when name is NULL,
   and returns check_status(); an unknown name runs nothing and returns 2 with one line
   naming it on stderr (prog: the program's name for that line). */
static inline int check_run(const char *prog, const char *name, const check_case_t *cases, size_t n)
{
    size_t i;
    int found = 0;
    for (i = 0; i < n; i++) {
        if (name == NULL || strcmp(name, cases[i].name) == 0) {
            cases[i].run();
            found = 1;
        }
    }
    if (!found) {
        fprintf(stderr, "%s: --case '%s': no such case (--list names them)\n", prog, name ? name : "");
        return 2;
    }
    return check_status();
}

/* check_main: main() of a test program with a case table of n cases; returns its exit status.
   Options: none runs every case, "--list" prints the names (check_list), "--case NAME" runs
   that case alone (check_run). inputs: NULL, or the usage of the one argument the program
   reads after the options (e.g. a vectors file: argv[argc - 1], which main() keeps for its
   cases before it calls check_main).
   Anything else is refused with exit status 2 and one line naming the argument. */
static inline int check_main(int argc, char **argv, const check_case_t *cases, size_t n, const char *inputs)
{
    int nin = inputs ? 1 : 0, i = 1, bad;
    const char *name = NULL;
    if (argc == 2 && strcmp(argv[1], "--list") == 0) {
        check_list(cases, n);
        return EXIT_SUCCESS;
    }
    if (i + 1 < argc && strcmp(argv[i], "--case") == 0) {
        name = argv[i + 1];
        i += 2;
    }
    if (argc - i == nin && (nin == 0 || argv[i][0] != '-')) {
        return check_run(argv[0], name, cases, n);
    }
    if (inputs && argc - i < nin) {
        fprintf(stderr, "%s: %s missing: usage: %s [--list | --case NAME] %s\n", argv[0], inputs, argv[0], inputs);
        return 2;
    }
    bad = (nin == 0 || argv[i][0] == '-') ? i : i + nin;
    fprintf(stderr, "%s: argument %d '%s': usage: %s [--list | --case NAME]%s%s\n", argv[0], bad, argv[bad], argv[0],
            inputs ? " " : "", inputs ? inputs : "");
    return 2;
}

#endif

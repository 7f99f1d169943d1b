/* The FMI 2.0 logger callback is C-variadic (printf style), which stable Rust cannot define.
 * This shim expands the message with vsnprintf and hands the text to the importer's sink. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void (*lash_log_sink)(void *env, int status, const char *category, const char *message);

static lash_log_sink sink = 0;

void lash_fmi2_set_log_sink(lash_log_sink s) { sink = s; }

void lash_fmi2_logger(void *env, const char *instance, int status, const char *category, const char *format, ...) {
    (void)instance;
    if (!sink || !format) return;
    char buffer[1024];
    va_list args;
    va_start(args, format);
    int n = vsnprintf(buffer, sizeof buffer, format, args);
    va_end(args);
    if (n < 0) {
        sink(env, status, category, format);
        return;
    }
    if ((size_t)n < sizeof buffer) {
        sink(env, status, category, buffer);
        return;
    }
    char *big = malloc((size_t)n + 1);
    if (!big) {
        sink(env, status, category, buffer);
        return;
    }
    va_start(args, format);
    vsnprintf(big, (size_t)n + 1, format, args);
    va_end(args);
    sink(env, status, category, big);
    free(big);
}

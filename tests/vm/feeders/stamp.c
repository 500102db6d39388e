/*
 * stamp: copies standard input to standard output line by line, each line
 * prefixed with the CLOCK_MONOTONIC time (µs) at which it was read:
 * `<mono_us> <line>`. The guest pipes `sipnpuff run` through it to time
 * when each event reaches a reader, against the feeders' logs (same clock).
 */
#include "common.h"

int main(void)
{
    prog = "stamp";
    char buf[65536];
    size_t len = 0;
    int64_t line_start = 0;
    for (;;) {
        ssize_t n = read(0, buf + len, sizeof buf - len);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            die("read: %s", strerror(errno));
        }
        int64_t now = mono_ns();
        if (n == 0)
            break;
        if (len == 0)
            line_start = now;
        len += (size_t)n;
        size_t from = 0;
        for (size_t i = 0; i < len; i++) {
            if (buf[i] != '\n')
                continue;
            printf("%lld %.*s\n", (long long)(line_start / 1000), (int)(i - from), buf + from);
            from = i + 1;
            line_start = now;
        }
        fflush(stdout);
        memmove(buf, buf + from, len - from);
        len -= from;
        if (len == sizeof buf) { /* a line longer than the buffer: pass it on */
            printf("%lld %.*s\n", (long long)(line_start / 1000), (int)len, buf);
            len = 0;
        }
    }
    if (len)
        printf("%lld %.*s\n", (long long)(line_start / 1000), (int)len, buf);
    return 0;
}

/*
 * probe: reads a device the way a program under test would, for a while,
 * and says what arrived. The guest uses it to check each simulated device
 * on its own (the device appears, values arrive at the feeder's rate)
 * before `sipnpuff` reads it, so a failure says which layer broke.
 *
 *   probe evdev DEV SECONDS    input events: the device's name, its X
 *                              axis, ABS_X events and their range,
 *                              BTN_TRIGGER and BTN_THUMB presses, SYN
 *                              reports (the input core sends only changes)
 *   probe lines DEV SECONDS    a tty in raw mode: lines per second, the
 *                              first and the last line
 *   probe sysfs FILE SECONDS   an IIO `_raw` file, pread on a kept-open fd
 *                              every ms: reads, changes, min and max
 *
 * Prints one line `probe <kind>: key=value ...` for the guest to parse.
 */
#include "common.h"
#include <linux/input.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>

/* Waits until `fd` is readable (1) or the moment `end` (CLOCK_MONOTONIC,
 * ns) has come (0). */
static int readable_before(int fd, int64_t end)
{
    for (;;) {
        int left = (int)((end - mono_ns()) / 1000000);
        if (left <= 0)
            return 0;
        struct pollfd pfd = {.fd = fd, .events = POLLIN};
        if (poll(&pfd, 1, left) > 0)
            return 1;
    }
}

static int probe_evdev(const char *dev, double seconds)
{
    int fd = open(dev, O_RDONLY | O_NONBLOCK);
    if (fd < 0)
        die("cannot open %s: %s", dev, strerror(errno));
    char name[256] = "";
    if (ioctl(fd, EVIOCGNAME(sizeof name), name) < 0)
        die("EVIOCGNAME %s: %s", dev, strerror(errno));
    struct input_absinfo abs;
    int has_x = ioctl(fd, EVIOCGABS(ABS_X), &abs) == 0;
    long x_events = 0, syn = 0, trig = 0, thumb = 0, xmin = 1L << 30, xmax = -(1L << 30);
    int64_t end = mono_ns() + (int64_t)(seconds * 1e9);
    while (readable_before(fd, end)) {
        struct input_event ev[64];
        ssize_t n = read(fd, ev, sizeof ev);
        for (ssize_t i = 0; n > 0 && i < n / (ssize_t)sizeof ev[0]; i++) {
            if (ev[i].type == EV_ABS && ev[i].code == ABS_X) {
                x_events++;
                if (ev[i].value < xmin)
                    xmin = ev[i].value;
                if (ev[i].value > xmax)
                    xmax = ev[i].value;
            } else if (ev[i].type == EV_KEY && ev[i].value == 1) {
                trig += ev[i].code == BTN_TRIGGER;
                thumb += ev[i].code == BTN_THUMB;
            } else if (ev[i].type == EV_SYN && ev[i].code == SYN_REPORT) {
                syn++;
            }
        }
    }
    printf("probe evdev: name=\"%s\" abs_x=%s abs_min=%d abs_max=%d fuzz=%d flat=%d x_events=%ld "
           "x_min=%ld x_max=%ld trigger_presses=%ld thumb_presses=%ld syn_reports=%ld\n",
           name, has_x ? "yes" : "no", has_x ? abs.minimum : 0, has_x ? abs.maximum : 0,
           has_x ? abs.fuzz : 0, has_x ? abs.flat : 0, x_events, x_events ? xmin : 0,
           x_events ? xmax : 0, trig, thumb, syn);
    return 0;
}

static int probe_lines(const char *dev, double seconds)
{
    int fd = open(dev, O_RDWR | O_NOCTTY);
    if (fd < 0)
        die("cannot open %s: %s", dev, strerror(errno));
    struct termios t;
    if (tcgetattr(fd, &t) == 0) {
        cfmakeraw(&t);
        tcsetattr(fd, TCSANOW, &t);
    }
    long lines = 0;
    char first[128] = "", last[128] = "", cur[128];
    size_t cur_len = 0;
    int64_t start = mono_ns(), end = start + (int64_t)(seconds * 1e9), first_at = 0, last_at = 0;
    while (readable_before(fd, end)) {
        char buf[4096];
        ssize_t n = read(fd, buf, sizeof buf);
        for (ssize_t i = 0; i < n; i++) {
            if (buf[i] == '\n') {
                cur[cur_len] = 0;
                if (cur_len && cur[cur_len - 1] == '\r')
                    cur[cur_len - 1] = 0;
                if (lines == 0) {
                    strcpy(first, cur);
                    first_at = mono_ns();
                }
                strcpy(last, cur);
                last_at = mono_ns();
                lines++;
                cur_len = 0;
            } else if (cur_len < sizeof cur - 1) {
                cur[cur_len++] = buf[i];
            }
        }
    }
    double span = lines > 1 ? (double)(last_at - first_at) / 1e9 : 0;
    printf("probe lines: lines=%ld lines_per_s=%.1f first=\"%s\" last=\"%s\"\n", lines,
           span > 0 ? (lines - 1) / span : 0, first, last);
    return 0;
}

static int probe_sysfs(const char *path, double seconds)
{
    int fd = open(path, O_RDONLY);
    if (fd < 0)
        die("cannot open %s: %s", path, strerror(errno));
    long reads = 0, changes = 0, prev = 0, vmin = 1L << 30, vmax = -(1L << 30), errors = 0;
    int64_t start = mono_ns(), end = start + (int64_t)(seconds * 1e9), deadline = start;
    while (mono_ns() < end) {
        char buf[32];
        ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
        if (n <= 0) {
            errors++;
        } else {
            buf[n] = 0;
            long v = strtol(buf, NULL, 10);
            if (reads > 0 && v != prev)
                changes++;
            prev = v;
            if (v < vmin)
                vmin = v;
            if (v > vmax)
                vmax = v;
            reads++;
        }
        deadline += 1000000;
        sleep_until_ns(deadline);
    }
    double span = (double)(mono_ns() - start) / 1e9;
    printf("probe sysfs: reads=%ld reads_per_s=%.1f changes=%ld min=%ld max=%ld errors=%ld\n", reads,
           reads / span, changes, reads ? vmin : 0, reads ? vmax : 0, errors);
    return 0;
}

int main(int argc, char **argv)
{
    prog = "probe";
    if (argc != 4)
        die("usage: probe evdev|lines|sysfs PATH SECONDS");
    double seconds = (double)parse_long(argv[3], "SECONDS", 1, 3600);
    if (!strcmp(argv[1], "evdev"))
        return probe_evdev(argv[2], seconds);
    if (!strcmp(argv[1], "lines"))
        return probe_lines(argv[2], seconds);
    if (!strcmp(argv[1], "sysfs"))
        return probe_sysfs(argv[2], seconds);
    die("unknown kind \"%s\": choose evdev, lines or sysfs", argv[1]);
    return 1;
}

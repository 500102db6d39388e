/*
 * serialfeed: plays the breath pattern on the gadget side of a USB CDC-ACM
 * serial device (/dev/ttyGS0; the program under test reads /dev/ttyACM0),
 * in raw mode, in one of three line formats:
 *
 *   volts      `2.500\n` every period (default 1 ms, 1 kHz)
 *   flipmouse  waits for `AT SR\r`, then `VALUES:<p>,0,0,0,0,0,0,0,0\r\n`
 *              every 50 ms, p = round(volts / 5 * 1023) (FLipMouse/FABI)
 *   lipsync    waits for `DM,1:2`, then
 *              `SUCCESS,0:DEBUG,2:<mouthpiece>,<ambient>,<diff>,<offset>\r\n`
 *              every 100 ms, hPa: diff = (volts - 2.5) / volts_per_hpa
 *              (0.05 V per hPa), ambient 1013.25, mouthpiece = ambient + diff,
 *              offset 0 (LipSync v4)
 *
 *   serialfeed [options] PATTERN
 *     --format volts|flipmouse|lipsync
 *     --period-us N            override the format's period
 *     --ends FILE              log the moment each breath ends
 *     --linger                 after the pattern, keep sending its last
 *                              level until SIGTERM
 *     --udc-file PATH          the gadget's configfs UDC file, for the
 *                              pattern's `unplug` and `replug`
 *     --keep-going             a failed write (the gadget unbound) is
 *                              counted and the pattern goes on
 *     --fifo PRIO, --cpu N     SCHED_FIFO priority, CPU
 *     --dev PATH               default /dev/ttyGS0
 *     --start-when-open PATH   begin once another process has PATH open
 *                              (the dialects: after their start command)
 *     --sync-rt                then send the neutral until that process
 *                              runs a real-time thread (its control loop)
 *     --wait-s N               how long to wait for the start command or the
 *                              reader (default 60)
 *
 * Whatever the host sends while the pattern plays is read and logged to
 * stderr at the end (a real device would act on it; these only stream).
 */
#include "common.h"
#include <poll.h>
#include <termios.h>

enum format { VOLTS, FLIPMOUSE, LIPSYNC };

#define VOLTS_PER_HPA 0.05
#define AMBIENT_HPA 1013.25

struct ser {
    int fd;
    enum format format;
    char heard[512];
    size_t heard_len;
};

/* Reads what the host sent, without waiting; keeps the first bytes. */
static void drain(struct ser *s)
{
    struct pollfd pfd = {.fd = s->fd, .events = POLLIN};
    while (poll(&pfd, 1, 0) == 1 && (pfd.revents & POLLIN)) {
        char buf[256];
        ssize_t n = read(s->fd, buf, sizeof buf);
        if (n <= 0)
            return;
        for (ssize_t i = 0; i < n && s->heard_len < sizeof s->heard - 1; i++)
            s->heard[s->heard_len++] = buf[i];
    }
}

static int write_all(int fd, const char *buf, size_t len)
{
    while (len > 0) {
        ssize_t n = write(fd, buf, len);
        if (n < 0) {
            if (errno == EINTR && !stop_requested)
                continue;
            return -1;
        }
        buf += n;
        len -= (size_t)n;
    }
    return 0;
}

static int emit(double volts, void *ctx)
{
    struct ser *s = ctx;
    char line[128];
    int n;
    switch (s->format) {
    case VOLTS:
        n = snprintf(line, sizeof line, "%.3f\n", volts);
        break;
    case FLIPMOUSE:
        n = snprintf(line, sizeof line, "VALUES:%ld,0,0,0,0,0,0,0,0\r\n", lround(volts / 5.0 * 1023.0));
        break;
    default: {
        double diff = (volts - 2.5) / VOLTS_PER_HPA;
        n = snprintf(line, sizeof line, "SUCCESS,0:DEBUG,2:%.2f,%.2f,%.2f,%.2f\r\n",
                     AMBIENT_HPA + diff, AMBIENT_HPA, diff, 0.0);
        break;
    }
    }
    drain(s);
    return write_all(s->fd, line, (size_t)n);
}

/* Reads until `command` has been received (anywhere in the input). */
static void wait_command(struct ser *s, const char *command, double timeout_s)
{
    char buf[1024];
    size_t len = 0;
    int64_t deadline = mono_ns() + (int64_t)(timeout_s * 1e9);
    for (;;) {
        int left_ms = (int)((deadline - mono_ns()) / 1000000);
        if (left_ms <= 0)
            die("no `%s` from the host within %.0f s (heard %zu bytes)", command, timeout_s, len);
        struct pollfd pfd = {.fd = s->fd, .events = POLLIN};
        int r = poll(&pfd, 1, left_ms);
        if (r < 0 && errno != EINTR)
            die("poll: %s", strerror(errno));
        if (r <= 0)
            continue;
        ssize_t n = read(s->fd, buf + len, sizeof buf - 1 - len);
        if (n < 0 && errno != EINTR && errno != EAGAIN)
            die("read: %s", strerror(errno));
        if (n <= 0)
            continue;
        len += (size_t)n;
        buf[len] = 0;
        if (memmem(buf, len, command, strlen(command))) {
            printf("%s: heard `%s`\n", prog, command);
            fflush(stdout);
            return;
        }
        if (len == sizeof buf - 1) { /* keep the tail, where the command may begin */
            memmove(buf, buf + len / 2, len - len / 2);
            len -= len / 2;
        }
    }
}

int main(int argc, char **argv)
{
    prog = "serialfeed";
    const char *dev = "/dev/ttyGS0", *format_name = "volts", *wait_text = "60";
    struct feed_options o = {.min_period_us = 100, .cpu = -1, .usb = 1};
    const struct own_option own[] = {
        {"--format", &format_name, NULL},
        {"--dev", &dev, NULL},
        {"--wait-s", &wait_text, NULL},
        {0},
    };
    parse_options(argc, argv, &o, own);
    enum format format = VOLTS;
    if (!strcmp(format_name, "flipmouse"))
        format = FLIPMOUSE;
    else if (!strcmp(format_name, "lipsync"))
        format = LIPSYNC;
    else if (strcmp(format_name, "volts"))
        die("--format: choose volts, flipmouse or lipsync, got \"%s\"", format_name);
    double wait_s = (double)parse_long(wait_text, "--wait-s", 1, 3600);
    if (o.period_us == 0)
        o.period_us = format == VOLTS ? 1000 : format == FLIPMOUSE ? 50000 : 100000;
    static struct pattern p;
    FILE *ends = begin_feed(&o, &p);

    int fd = open(dev, O_RDWR | O_NOCTTY);
    if (fd < 0)
        die("cannot open %s: %s", dev, strerror(errno));
    struct termios t;
    if (tcgetattr(fd, &t) != 0)
        die("tcgetattr %s: %s", dev, strerror(errno));
    cfmakeraw(&t);
    t.c_cc[VMIN] = 1;
    t.c_cc[VTIME] = 0;
    if (tcsetattr(fd, TCSANOW, &t) != 0)
        die("tcsetattr %s: %s", dev, strerror(errno));
    tcflush(fd, TCIOFLUSH);

    struct ser s = {.fd = fd, .format = format};
    if (format == FLIPMOUSE)
        wait_command(&s, "AT SR\r", wait_s);
    else if (format == LIPSYNC)
        wait_command(&s, "DM,1:2", wait_s);
    if (o.when_open)
        wait_open(o.when_open, wait_s);
    struct play_stats st = play(&p, o.period_us, emit, &s, ends);
    print_stats(format == VOLTS ? "volts lines" : format == FLIPMOUSE ? "VALUES lines" : "DEBUG lines",
                &st, o.period_us);
    if (s.heard_len) {
        fprintf(stderr, "%s: heard while streaming: \"", prog);
        for (size_t i = 0; i < s.heard_len; i++) {
            unsigned char c = (unsigned char)s.heard[i];
            if (c >= 32 && c < 127)
                fputc(c, stderr);
            else
                fprintf(stderr, "\\x%02x", c);
        }
        fprintf(stderr, "\"\n");
    }
    if (ends)
        fclose(ends);
    return st.stopped_by_error ? 1 : 0;
}

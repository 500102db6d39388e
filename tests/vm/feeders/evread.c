/*
 * evread: reads the input device sipnpuff makes through uinput, the way a
 * desktop would (evdev), independently of sipnpuff's code, and logs every
 * event with its kernel timestamp.
 *
 *   evread [options]               log the events of the device named NAME
 *     --name NAME                  its name, exactly (default "sipnpuff"),
 *                                  found through /sys/class/input/event*
 *     --wait-s S                   wait this long for it (default 30)
 *     --log FILE                   the event log (default: none)
 *     --seconds S                  give up after S s with the device still
 *                                  there (default 600)
 *     --term-on-key CODE --pid PID send SIGTERM to PID right after reading
 *                                  the first press of key CODE
 *     --fifo PRIO, --cpu N         SCHED_FIFO priority, CPU
 *   evread stuck NAME SECONDS      the control: make a uinput device NAME,
 *                                  press KEY_LEFTCTRL and exit after SECONDS
 *                                  without letting go of it
 *
 * The events are stamped by the kernel on CLOCK_MONOTONIC (EVIOCSCLOCKID),
 * the clock of the harness's `stamp`, so they can be set against
 * sipnpuff's event lines. Log lines:
 *   # found DEV "NAME" MONO_US
 *   EVENT_US READ_US TYPE CODE VALUE      (EV_KEY KEY_LEFTCTRL 1, EV_SYN SYN_REPORT 0)
 *   # sigterm MONO_US PID
 *   # end MONO_US removed|timeout
 * The reader ends when the device goes away (a read fails with ENODEV) and
 * prints one line: the events and frames seen, the keys still down at the
 * end, the keys the kernel let go of (the input core releases the keys of a
 * device being removed, in a frame closed by SYN_REPORT with value 1; a
 * program that lets go itself writes SYN_REPORT 0), the sums of REL_X,
 * REL_Y and REL_WHEEL, and how long after the last event the device went.
 */
#include "common.h"
#include <linux/input.h>
#include <linux/uinput.h>
#include <poll.h>
#include <sys/ioctl.h>

#define NKEYS (KEY_MAX + 1)

static const char *type_name(unsigned type, char *buf, size_t n)
{
    switch (type) {
    case EV_SYN: return "EV_SYN";
    case EV_KEY: return "EV_KEY";
    case EV_REL: return "EV_REL";
    case EV_MSC: return "EV_MSC";
    }
    snprintf(buf, n, "EV_%u", type);
    return buf;
}

static const char *code_name(unsigned type, unsigned code, char *buf, size_t n)
{
    if (type == EV_SYN && code == SYN_REPORT)
        return "SYN_REPORT";
    if (type == EV_SYN && code == SYN_DROPPED)
        return "SYN_DROPPED";
    if (type == EV_REL) {
        switch (code) {
        case REL_X: return "REL_X";
        case REL_Y: return "REL_Y";
        case REL_WHEEL: return "REL_WHEEL";
        }
    }
    if (type == EV_KEY) {
        switch (code) {
        case KEY_LEFTCTRL: return "KEY_LEFTCTRL";
        case KEY_LEFTALT: return "KEY_LEFTALT";
        case KEY_LEFTSHIFT: return "KEY_LEFTSHIFT";
        case KEY_LEFTMETA: return "KEY_LEFTMETA";
        case KEY_T: return "KEY_T";
        case BTN_LEFT: return "BTN_LEFT";
        case BTN_RIGHT: return "BTN_RIGHT";
        case BTN_MIDDLE: return "BTN_MIDDLE";
        }
    }
    snprintf(buf, n, "CODE_%u", code);
    return buf;
}

/* The /dev/input/eventN whose device is named `name`, into `dev`. */
static int find_device(const char *name, char *dev, size_t n)
{
    DIR *d = opendir("/sys/class/input");
    if (!d)
        return 0;
    struct dirent *e;
    int found = 0;
    while (!found && (e = readdir(d))) {
        if (strncmp(e->d_name, "event", 5) != 0)
            continue;
        char path[PATH_MAX], got[256];
        snprintf(path, sizeof path, "/sys/class/input/%s/device/name", e->d_name);
        FILE *f = fopen(path, "r");
        if (!f)
            continue;
        if (fgets(got, sizeof got, f)) {
            got[strcspn(got, "\n")] = 0;
            if (!strcmp(got, name)) {
                snprintf(dev, n, "/dev/input/%s", e->d_name);
                found = 1;
            }
        }
        fclose(f);
    }
    closedir(d);
    return found;
}

static void emit(int fd, unsigned type, unsigned code, int value)
{
    struct input_event ev;
    memset(&ev, 0, sizeof ev);
    ev.type = (unsigned short)type;
    ev.code = (unsigned short)code;
    ev.value = value;
    if (write(fd, &ev, sizeof ev) != (ssize_t)sizeof ev)
        die("write to /dev/uinput: %s", strerror(errno));
}

/* The control: a program that ends with a key held. */
static int stuck(const char *name, double seconds)
{
    int fd = open("/dev/uinput", O_WRONLY);
    if (fd < 0)
        die("cannot open /dev/uinput: %s", strerror(errno));
    if (ioctl(fd, UI_SET_EVBIT, EV_KEY) < 0 || ioctl(fd, UI_SET_KEYBIT, KEY_LEFTCTRL) < 0 ||
        ioctl(fd, UI_SET_KEYBIT, KEY_T) < 0)
        die("UI_SET_*BIT: %s", strerror(errno));
    struct uinput_setup setup;
    memset(&setup, 0, sizeof setup);
    setup.id.bustype = BUS_VIRTUAL;
    snprintf(setup.name, sizeof setup.name, "%s", name);
    if (ioctl(fd, UI_DEV_SETUP, &setup) < 0 || ioctl(fd, UI_DEV_CREATE) < 0)
        die("UI_DEV_SETUP/UI_DEV_CREATE: %s", strerror(errno));
    usleep((useconds_t)(seconds * 1e6));
    emit(fd, EV_KEY, KEY_LEFTCTRL, 1);
    emit(fd, EV_SYN, SYN_REPORT, 0);
    usleep(100000);
    /* Exit with the key down: closing the fd destroys the device. */
    return 0;
}

int main(int argc, char **argv)
{
    prog = "evread";
    if (argc == 4 && !strcmp(argv[1], "stuck"))
        return stuck(argv[2], atof(argv[3]));
    const char *name = "sipnpuff", *log_path = NULL;
    double wait_s = 30, seconds = 600;
    long term_key = -1, term_pid = 0;
    int prio = 0, cpu = -1;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (i + 1 >= argc)
            die("option \"%s\" needs a value (see the comment at the top of evread.c)", a);
        const char *v = argv[++i];
        if (!strcmp(a, "--name"))
            name = v;
        else if (!strcmp(a, "--wait-s"))
            wait_s = (double)parse_long(v, a, 1, 3600);
        else if (!strcmp(a, "--seconds"))
            seconds = (double)parse_long(v, a, 1, 36000);
        else if (!strcmp(a, "--log"))
            log_path = v;
        else if (!strcmp(a, "--term-on-key"))
            term_key = parse_long(v, a, 0, KEY_MAX);
        else if (!strcmp(a, "--pid"))
            term_pid = parse_long(v, a, 1, 1 << 22);
        else if (!strcmp(a, "--fifo"))
            prio = (int)parse_long(v, a, 0, 99);
        else if (!strcmp(a, "--cpu"))
            cpu = (int)parse_long(v, a, 0, 1023);
        else
            die("unknown option \"%s\" (see the comment at the top of evread.c)", a);
    }
    if ((term_key >= 0) != (term_pid > 0))
        die("--term-on-key and --pid go together");
    FILE *log = open_log(log_path);
    realtime(prio, cpu);

    /* The device, and its event node open. */
    char dev[PATH_MAX];
    int64_t start = mono_ns(), deadline = start + (int64_t)(wait_s * 1e9);
    int fd = -1;
    for (;;) {
        if (find_device(name, dev, sizeof dev) && (fd = open(dev, O_RDONLY)) >= 0)
            break;
        if (mono_ns() > deadline)
            die("no input device named \"%s\" within %.0f s", name, wait_s);
        usleep(2000);
    }
    int64_t found = mono_ns();
    int clk = CLOCK_MONOTONIC;
    if (ioctl(fd, EVIOCSCLOCKID, &clk) < 0)
        die("EVIOCSCLOCKID: %s", strerror(errno));
    if (log) {
        fprintf(log, "# found %s \"%s\" %lld\n", dev, name, (long long)(found / 1000));
        fflush(log);
    }

    static unsigned char down[NKEYS];
    unsigned short frame_up[64];
    int n_frame_up = 0;
    long events = 0, frames = 0, kernel_released = 0, presses = 0, releases = 0;
    long long rel[3] = {0, 0, 0};
    char kernel_keys[512] = "";
    int64_t last_event_us = 0, end_us = 0;
    const char *how = "timeout";
    int64_t give_up = found + (int64_t)(seconds * 1e9);
    int termed = 0;
    for (;;) {
        int left = (int)((give_up - mono_ns()) / 1000000);
        if (left <= 0)
            break;
        struct pollfd pfd = {.fd = fd, .events = POLLIN};
        int r = poll(&pfd, 1, left);
        if (r < 0 && errno == EINTR)
            continue;
        if (r == 0)
            continue;
        struct input_event ev[64];
        ssize_t n = read(fd, ev, sizeof ev);
        int64_t now_us = mono_ns() / 1000;
        if (n < 0) {
            if (errno == EINTR || errno == EAGAIN)
                continue;
            if (errno == ENODEV) {
                how = "removed";
                end_us = now_us;
                break;
            }
            die("read %s: %s", dev, strerror(errno));
        }
        if (n == 0)
            continue;
        for (ssize_t i = 0; i < n / (ssize_t)sizeof ev[0]; i++) {
            struct input_event *e = &ev[i];
            int64_t ev_us = (int64_t)e->input_event_sec * 1000000 + e->input_event_usec;
            char tb[16], cb[16];
            events++;
            last_event_us = ev_us;
            if (log)
                fprintf(log, "%lld %lld %s %s %d\n", (long long)ev_us, (long long)now_us,
                        type_name(e->type, tb, sizeof tb), code_name(e->type, e->code, cb, sizeof cb),
                        e->value);
            if (e->type == EV_KEY && e->code < NKEYS) {
                if (e->value == 1 && !down[e->code]) {
                    down[e->code] = 1;
                    presses++;
                } else if (e->value == 0 && down[e->code]) {
                    down[e->code] = 0;
                    releases++;
                    if (n_frame_up < 64)
                        frame_up[n_frame_up++] = e->code;
                }
                if (e->value == 1 && (long)e->code == term_key && !termed) {
                    termed = 1;
                    kill((pid_t)term_pid, SIGTERM);
                    if (log)
                        fprintf(log, "# sigterm %lld %ld\n", (long long)(mono_ns() / 1000), term_pid);
                }
            } else if (e->type == EV_REL) {
                if (e->code == REL_X)
                    rel[0] += e->value;
                else if (e->code == REL_Y)
                    rel[1] += e->value;
                else if (e->code == REL_WHEEL)
                    rel[2] += e->value;
            } else if (e->type == EV_SYN && e->code == SYN_REPORT) {
                frames++;
                if (e->value == 1) {
                    /* The input core's own frame: keys let go of by the kernel. */
                    for (int k = 0; k < n_frame_up; k++) {
                        char nb[16];
                        size_t l = strlen(kernel_keys);
                        snprintf(kernel_keys + l, sizeof kernel_keys - l, "%s%s", l ? "," : "",
                                 code_name(EV_KEY, frame_up[k], nb, sizeof nb));
                        kernel_released++;
                    }
                }
                n_frame_up = 0;
            }
        }
        if (log)
            fflush(log);
    }
    if (!end_us)
        end_us = mono_ns() / 1000;
    if (log) {
        fprintf(log, "# end %lld %s\n", (long long)end_us, how);
        fclose(log);
    }
    char still[512] = "";
    for (int k = 0; k < NKEYS; k++) {
        if (!down[k])
            continue;
        char nb[16];
        size_t l = strlen(still);
        snprintf(still + l, sizeof still - l, "%s%s", l ? "," : "", code_name(EV_KEY, (unsigned)k, nb, sizeof nb));
    }
    printf("evread: %s \"%s\": events=%ld frames=%ld presses=%ld releases=%ld down_at_end=%s "
           "kernel_released=%s rel_x=%lld rel_y=%lld rel_wheel=%lld ended=%s gone_after_last_ms=%.1f "
           "sigterm=%s\n",
           dev, name, events, frames, presses, releases, still[0] ? still : "none",
           kernel_released ? kernel_keys : "none", rel[0], rel[1], rel[2], how,
           last_event_us ? (double)(end_us - last_event_us) / 1000.0 : 0.0,
           term_key < 0 ? "not-asked" : termed ? "sent" : "never");
    return 0;
}

/*
 * Shared by the VM harness's test drivers ("feeders"): the breath pattern
 * (tests/vm/pattern.txt: lines `<volts> <ms>`, `#` comments; the words
 * `unplug` and `replug` on a line of their own remove the USB device and
 * bring it back at that moment, see `udc_file`), a periodic
 * player on CLOCK_MONOTONIC with absolute deadlines, the log of the moments
 * a breath ends, and real-time set-up. Built with `gcc -static` by
 * tests/vm/run.sh and run inside the guest. Header-only: each feeder is
 * one .c file that includes this.
 *
 * Every error is a message on stderr and exit status 1; no feeder aborts.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <sched.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include <dirent.h>
#include <limits.h>
#include <unistd.h>

#define MAX_STEPS 4096

enum marker { NONE, UNPLUG, REPLUG };

/* A step plays `volts` for `ms`; a marker step (ms 0) unplugs or replugs
 * the device at that moment (see `udc_file`). */
struct step {
    double volts;
    long ms;
    enum marker marker;
};

struct pattern {
    struct step steps[MAX_STEPS];
    int n;
    long total_ms;
    double neutral; /* the first step's level: a breath is any other level */
};

static const char *prog = "feeder";

static inline void die(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "%s: ", prog);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    exit(1);
}

static inline int64_t mono_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

static inline void sleep_until_ns(int64_t t)
{
    struct timespec ts = {.tv_sec = t / 1000000000LL, .tv_nsec = t % 1000000000LL};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
    }
}

static inline void load_pattern(const char *path, struct pattern *p)
{
    FILE *f = fopen(path, "r");
    if (!f)
        die("cannot open the pattern %s: %s", path, strerror(errno));
    char line[256];
    int lineno = 0;
    p->n = 0;
    p->total_ms = 0;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        char *hash = strchr(line, '#');
        if (hash)
            *hash = 0;
        double v;
        long ms;
        char extra, word[16];
        enum marker marker = NONE;
        if (sscanf(line, "%15s %c", word, &extra) == 1) {
            if (!strcmp(word, "unplug"))
                marker = UNPLUG;
            else if (!strcmp(word, "replug"))
                marker = REPLUG;
        }
        if (marker != NONE) {
            if (p->n == 0)
                die("%s line %d: the pattern must begin with the neutral, not `%s`", path, lineno, word);
            if (p->n == MAX_STEPS)
                die("%s: more than %d steps", path, MAX_STEPS);
            p->steps[p->n] = (struct step){.volts = p->steps[p->n - 1].volts, .ms = 0, .marker = marker};
            p->n++;
            continue;
        }
        int got = sscanf(line, "%lf %ld %c", &v, &ms, &extra);
        if (got <= 0)
            continue; /* blank */
        if (got != 2 || !(v >= 0.0 && v <= 5.0) || ms <= 0)
            die("%s line %d: expected `<volts 0..5> <ms > 0>`", path, lineno);
        if (p->n == MAX_STEPS)
            die("%s: more than %d steps", path, MAX_STEPS);
        p->steps[p->n] = (struct step){.volts = v, .ms = ms, .marker = NONE};
        p->n++;
        p->total_ms += ms;
    }
    fclose(f);
    if (p->n == 0)
        die("%s: no steps", path);
    p->neutral = p->steps[0].volts;
}

/* The step playing at `ms` from the start, or -1 past the end (markers
 * last 0 ms: never playing). */
static inline int step_at(const struct pattern *p, long ms)
{
    long t = 0;
    for (int i = 0; i < p->n; i++) {
        t += p->steps[i].ms;
        if (ms < t)
            return i;
    }
    return -1;
}

/* The gadget's configfs UDC file and the controller to bind: `unplug`
 * writes an empty line to it (the host sees the device go away), `replug`
 * the controller's name. Unset: markers are errors. */
static const char *udc_file;
static const char *udc_name = "dummy_udc.0";

static inline void udc_write(const char *value)
{
    if (!udc_file)
        die("the pattern unplugs the device but no --udc-file was given");
    int fd = open(udc_file, O_WRONLY);
    if (fd < 0)
        die("cannot open %s: %s", udc_file, strerror(errno));
    char line[64];
    int n = snprintf(line, sizeof line, "%s\n", value);
    if (write(fd, line, (size_t)n) != n)
        die("writing \"%s\" to %s: %s", value, udc_file, strerror(errno));
    close(fd);
}

/* SCHED_FIFO at `prio` (0: leave as is), memory locked, pinned to `cpu`
 * (-1: any). A feeder stands in for hardware: it should keep its rate. */
static inline void realtime(int prio, int cpu)
{
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
        fprintf(stderr, "%s: mlockall: %s (continuing)\n", prog, strerror(errno));
    if (cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET(cpu, &set);
        if (sched_setaffinity(0, sizeof set, &set) != 0)
            fprintf(stderr, "%s: pin to CPU %d: %s (continuing)\n", prog, cpu, strerror(errno));
    }
    if (prio > 0) {
        struct sched_param sp = {.sched_priority = prio};
        if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0)
            fprintf(stderr, "%s: SCHED_FIFO %d: %s (continuing)\n", prog, prio, strerror(errno));
    }
}

/*
 * Waits until another process holds `path` open (the program under test
 * has opened the device), polling /proc/<pid>/fd every 2 ms, up to
 * `timeout_s`. A feeder started this way begins its pattern when the reader
 * is there, as a device that is plugged in before the program starts would
 * be seen from the program's first read.
 */
static pid_t opener_pid; /* who opened the device, found by wait_open */

static inline void wait_open(const char *path, double timeout_s)
{
    char want[PATH_MAX];
    if (!realpath(path, want))
        die("--start-when-open %s: %s", path, strerror(errno));
    int64_t deadline = mono_ns() + (int64_t)(timeout_s * 1e9);
    pid_t self = getpid();
    for (;;) {
        DIR *proc = opendir("/proc");
        if (!proc)
            die("cannot read /proc: %s", strerror(errno));
        struct dirent *d;
        while ((d = readdir(proc))) {
            char *end;
            long pid = strtol(d->d_name, &end, 10);
            if (*end || pid <= 0 || pid == self)
                continue;
            char fddir[64];
            snprintf(fddir, sizeof fddir, "/proc/%ld/fd", pid);
            DIR *fds = opendir(fddir);
            if (!fds)
                continue;
            struct dirent *e;
            while ((e = readdir(fds))) {
                char link[PATH_MAX], target[PATH_MAX];
                if (e->d_name[0] == '.')
                    continue;
                snprintf(link, sizeof link, "%s/%s", fddir, e->d_name);
                ssize_t n = readlink(link, target, sizeof target - 1);
                if (n <= 0)
                    continue;
                target[n] = 0;
                if (!strcmp(target, want)) {
                    closedir(fds);
                    closedir(proc);
                    opener_pid = (pid_t)pid;
                    return;
                }
            }
            closedir(fds);
        }
        closedir(proc);
        if (mono_ns() > deadline)
            die("no process opened %s within %.0f s", want, timeout_s);
        usleep(2000);
    }
}

/*
 * Whether a thread of `pid` runs under SCHED_FIFO or SCHED_RR (field 41 of
 * /proc/PID/task/TID/stat): sipnpuff's control loop has started. The
 * start-up before it (the re-zero, locking memory) takes 1-4 s under
 * emulation; a pattern begun at the open could have its first breath
 * before the loop runs.
 */
static inline int rt_thread(pid_t pid)
{
    char dir[64];
    snprintf(dir, sizeof dir, "/proc/%d/task", (int)pid);
    DIR *tasks = opendir(dir);
    if (!tasks)
        return 0;
    struct dirent *t;
    int found = 0;
    while (!found && (t = readdir(tasks))) {
        if (t->d_name[0] == '.')
            continue;
        char path[PATH_MAX], buf[1024];
        snprintf(path, sizeof path, "%s/%s/stat", dir, t->d_name);
        int fd = open(path, O_RDONLY);
        if (fd < 0)
            continue;
        ssize_t n = read(fd, buf, sizeof buf - 1);
        close(fd);
        if (n <= 0)
            continue;
        buf[n] = 0;
        char *p = strrchr(buf, ')'); /* the name may hold spaces */
        if (!p)
            continue;
        /* After ") ": field 3 onwards; the policy is field 41. */
        int field = 2;
        for (char *tok = strtok(p + 1, " "); tok; tok = strtok(NULL, " ")) {
            if (++field == 41) {
                int policy = atoi(tok);
                found = policy == SCHED_FIFO || policy == SCHED_RR;
                break;
            }
        }
    }
    closedir(tasks);
    return found;
}

/*
 * Plays the pattern: every `period_us` (absolute deadlines from the start),
 * `emit(volts, ctx)` sends the level due now. A feeder late by more than a
 * period skips to the level due now (a device sends its current value,
 * never a backlog) and counts the periods it missed. When a write ends a
 * breath (the first emit of a neutral step after a breath), the moment just
 * before it is logged to `ends` as `end <n> <mono_us> <volts_of_breath>
 * <step_ms>`. `emit` returns 0, or -1 to stop (errno set; EINTR after a
 * stop request is a normal stop). With `linger`, the last level goes on
 * until SIGTERM or SIGINT.
 */
struct play_stats {
    long emitted;
    long missed_periods;
    long breaths_ended;
    long failed_writes; /* with keep_going */
    long waited_emits;  /* the neutral sent while waiting (sync_rt) */
    double waited_ms;
    double seconds;
    int stopped_by_error;
    int error;
};

static volatile sig_atomic_t stop_requested;
/* After the pattern, keep sending its last level until SIGTERM/SIGINT (a
 * device stays plugged in after the user stops breathing). */
static int linger;
/* A failed write (the device unplugged) is counted and the pattern goes
 * on, instead of ending the feeder: the device comes back later. */
static int keep_going;
static inline void on_stop(int sig)
{
    (void)sig;
    stop_requested = 1;
}

static inline void catch_stop_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
}

/* With `sync_rt`, the neutral is sent at the period until the device's
 * opener (see wait_open) runs a real-time thread, and only then does the
 * pattern begin. */
static int sync_rt;

static inline struct play_stats play(const struct pattern *p, long period_us,
                              int (*emit)(double volts, void *ctx), void *ctx, FILE *ends)
{
    struct play_stats st = {0};
    int64_t period = (int64_t)period_us * 1000;
    if (sync_rt) {
        if (!opener_pid)
            die("--sync-rt needs --start-when-open (whose real-time thread to wait for)");
        int64_t t0 = mono_ns(), next_check = t0, d = t0;
        for (;;) {
            int64_t now = mono_ns();
            if (now >= next_check) {
                if (rt_thread(opener_pid))
                    break;
                if (kill(opener_pid, 0) != 0)
                    die("process %d ended before its real-time thread started", (int)opener_pid);
                if (now - t0 > 60000000000LL)
                    die("process %d ran no real-time thread within 60 s", (int)opener_pid);
                next_check = now + 5000000;
            }
            if (emit(p->neutral, ctx) != 0 && !keep_going)
                die("write while waiting for the control loop: %s", strerror(errno));
            st.waited_emits++;
            d += period;
            if (mono_ns() > d + period)
                d = mono_ns();
            sleep_until_ns(d);
        }
        st.waited_ms = (double)(mono_ns() - t0) / 1e6;
    }
    int64_t start = mono_ns();
    int64_t deadline = start;
    int in_breath = 0;
    double breath_volts = 0;
    long breath_ms = 0;
    int last = -1; /* the last step played: markers passed since then fire */
    while (!stop_requested) {
        int64_t now = mono_ns();
        long ms = (long)((now - start) / 1000000);
        int i = step_at(p, ms);
        if (i < 0 && !linger)
            break;
        if (i < 0)
            i = p->n - 1;
        for (int k = last + 1; k <= i; k++) {
            if (p->steps[k].marker == NONE)
                continue;
            int64_t at = mono_ns();
            udc_write(p->steps[k].marker == UNPLUG ? "" : udc_name);
            if (ends) {
                fprintf(ends, "%s %lld\n", p->steps[k].marker == UNPLUG ? "unplug" : "replug",
                        (long long)(at / 1000));
                fflush(ends);
            }
        }
        last = i;
        double v = p->steps[i].volts;
        int breath = v != p->neutral;
        int64_t before = mono_ns();
        if (emit(v, ctx) != 0) {
            if (stop_requested && errno == EINTR)
                break;
            if (keep_going) {
                st.failed_writes++;
                st.error = errno;
                usleep(1000);
                continue;
            }
            st.stopped_by_error = 1;
            st.error = errno;
            break;
        }
        st.emitted++;
        if (breath) {
            in_breath = 1;
            breath_volts = v;
            breath_ms = p->steps[i].ms;
        } else if (in_breath) {
            in_breath = 0;
            st.breaths_ended++;
            if (ends) {
                fprintf(ends, "end %ld %lld %.3f %ld\n", st.breaths_ended,
                        (long long)(before / 1000), breath_volts, breath_ms);
                fflush(ends);
            }
        }
        deadline += period;
        now = mono_ns();
        if (now > deadline + period) {
            long behind = (long)((now - deadline) / period);
            st.missed_periods += behind;
            deadline += (int64_t)behind * period;
        }
        sleep_until_ns(deadline);
    }
    st.seconds = (double)(mono_ns() - start) / 1e9;
    return st;
}

static inline void print_stats(const char *what, const struct play_stats *st, long period_us)
{
    double rate = st->seconds > 0 ? st->emitted / st->seconds : 0;
    printf("%s: %ld %s in %.3f s = %.1f/s (target %.1f/s), %ld periods missed, %ld breaths ended",
           prog, st->emitted, what, st->seconds, rate, 1e6 / period_us, st->missed_periods,
           st->breaths_ended);
    if (st->waited_emits)
        printf(", after %.0f ms at the neutral waiting for the control loop", st->waited_ms);
    if (st->failed_writes)
        printf(", %ld writes failed (last: %s)", st->failed_writes, strerror(st->error));
    if (st->stopped_by_error)
        printf(", stopped by error: %s", strerror(st->error));
    printf("\n");
    fflush(stdout);
}

static inline FILE *open_log(const char *path)
{
    if (!path)
        return NULL;
    FILE *f = fopen(path, "w");
    if (!f)
        die("cannot write %s: %s", path, strerror(errno));
    return f;
}

static inline long parse_long(const char *s, const char *what, long lo, long hi)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || *end || end == s || v < lo || v > hi)
        die("%s must be an integer in %ld..%ld, got \"%s\"", what, lo, hi, s);
    return v;
}

/* What every feeder's command line gives: the pattern, the log of breath
 * ends, the device's opener to wait for, the period (at least
 * `min_period_us`) and the real-time set-up; with `usb`, also the
 * gadget's --udc-file and --keep-going. The flags set the globals above. */
struct feed_options {
    const char *pattern_path, *ends_path, *when_open;
    long period_us, min_period_us;
    int prio, cpu, usb;
};

/* Takes argv[*i] and its value (moving *i past it) if it is a valued
 * option every feeder takes; 0 if it is not. */
static inline int feed_value_option(int argc, char **argv, int *i, struct feed_options *o)
{
    const char *a = argv[*i];
    if (*i + 1 >= argc)
        return 0;
    const char *value = argv[*i + 1];
    if (!strcmp(a, "--period-us"))
        o->period_us = parse_long(value, a, o->min_period_us, 10000000);
    else if (!strcmp(a, "--udc-file") && o->usb)
        udc_file = value;
    else if (!strcmp(a, "--ends"))
        o->ends_path = value;
    else if (!strcmp(a, "--fifo"))
        o->prio = (int)parse_long(value, a, 0, 99);
    else if (!strcmp(a, "--cpu"))
        o->cpu = (int)parse_long(value, a, 0, 1023);
    else if (!strcmp(a, "--start-when-open"))
        o->when_open = value;
    else
        return 0;
    (*i)++;
    return 1;
}

/* Takes argv[*i] if it is an option every feeder takes (with its value,
 * moving *i past it) or the pattern; 0 if it is not. */
static inline int feed_option(int argc, char **argv, int *i, struct feed_options *o)
{
    const char *a = argv[*i];
    if (!strcmp(a, "--linger"))
        linger = 1;
    else if (!strcmp(a, "--sync-rt"))
        sync_rt = 1;
    else if (!strcmp(a, "--keep-going") && o->usb)
        keep_going = 1;
    else if (a[0] != '-' && !o->pattern_path)
        o->pattern_path = a;
    else
        return feed_value_option(argc, argv, i, o);
    return 1;
}

/* One of a feeder's own options: a flag sets `*flag` to 1; an option with
 * a value points `*value` at it. A table of them ends with {0}. */
struct own_option {
    const char *name;
    const char **value;
    int *flag;
};

/* Parses the command line: the options every feeder takes into `o`, the
 * feeder's own by the table `own`; anything else is an error. */
static inline void parse_options(int argc, char **argv, struct feed_options *o,
                                 const struct own_option *own)
{
    for (int i = 1; i < argc; i++) {
        if (feed_option(argc, argv, &i, o))
            continue;
        const struct own_option *opt = own;
        while (opt->name && strcmp(opt->name, argv[i]))
            opt++;
        if (!opt->name || (opt->value && i + 1 >= argc))
            die("unknown or incomplete option \"%s\" (see the comment at the top of %s.c)", argv[i],
                prog);
        if (opt->flag)
            *opt->flag = 1;
        else
            *opt->value = argv[++i];
    }
}

/* The level `--prime` gives: volts 0..5. */
static inline double prime_volts(const char *text)
{
    char *end;
    double v = strtod(text, &end);
    if (*end || end == text || !(v >= 0 && v <= 5))
        die("--prime takes volts 0..5, got \"%s\"", text);
    return v;
}

/* Loads the pattern the options name into `p`, opens the log of breath
 * ends (NULL without one), catches SIGTERM/SIGINT and goes real-time. */
static inline FILE *begin_feed(const struct feed_options *o, struct pattern *p)
{
    if (!o->pattern_path)
        die("no pattern given");
    load_pattern(o->pattern_path, p);
    FILE *ends = open_log(o->ends_path);
    catch_stop_signals();
    realtime(o->prio, o->cpu);
    return ends;
}

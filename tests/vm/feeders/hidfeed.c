/*
 * hidfeed: plays the breath pattern as USB HID joystick reports on the
 * gadget's /dev/hidg0 (the gadget is made by the guest script through
 * configfs; its report descriptor is in tests/vm/guest/init).
 *
 * A report is 2 bytes, little-endian: bits 0-9 the X axis (0..1023,
 * X = round(volts / 5 * 1023)), bit 10 button 1 (BTN_TRIGGER), bit 11
 * button 2 (BTN_THUMB).
 *
 *   hidfeed [options] PATTERN     play the pattern, one report per period
 *     --buttons                   the level as switches instead: X stays at
 *                                 the neutral; button 1 held while the level
 *                                 is a sip (below the neutral), button 2
 *                                 while a puff (above)
 *     --period-us N               report period (default 1000)
 *     --ends FILE                 log the moment each breath ends
 *     --linger                    after the pattern, keep sending its last
 *                                 level until SIGTERM
 *     --udc-file PATH             the gadget's configfs UDC file, for the
 *                                 pattern's `unplug` and `replug`
 *     --keep-going                a failed write (the gadget unbound) is
 *                                 counted and the pattern goes on
 *     --fifo PRIO, --cpu N        SCHED_FIFO priority, CPU
 *     --dev PATH                  default /dev/hidg0
 *     --start-when-open PATH      begin once another process has PATH open
 *     --sync-rt                   then send the neutral until that process
 *                                 runs a real-time thread (its control loop)
 *   hidfeed --prime VOLTS [--dev PATH]   write one report and exit
 *
 * A write blocks until the host side has taken the previous report (usbhid
 * polls only while the event node is open); a feeder held up that way skips
 * to the level due now and counts the periods missed.
 */
#include "common.h"

struct hid {
    int fd;
    int buttons;
    double neutral;
};

static unsigned axis(double volts)
{
    long x = lround(volts / 5.0 * 1023.0);
    if (x < 0)
        x = 0;
    if (x > 1023)
        x = 1023;
    return (unsigned)x;
}

static int write_report(int fd, unsigned x, int b1, int b2)
{
    unsigned word = (x & 0x3ff) | (b1 ? 1u << 10 : 0) | (b2 ? 1u << 11 : 0);
    unsigned char r[2] = {word & 0xff, word >> 8};
    ssize_t n = write(fd, r, 2);
    if (n == 2)
        return 0;
    if (n >= 0)
        errno = EIO;
    return -1;
}

static int emit(double volts, void *ctx)
{
    struct hid *h = ctx;
    if (h->buttons)
        return write_report(h->fd, axis(h->neutral), volts < h->neutral, volts > h->neutral);
    return write_report(h->fd, axis(volts), 0, 0);
}

int main(int argc, char **argv)
{
    prog = "hidfeed";
    const char *dev = "/dev/hidg0", *prime = NULL;
    int buttons = 0;
    struct feed_options o = {.period_us = 1000, .min_period_us = 100, .cpu = -1, .usb = 1};
    const struct own_option own[] = {
        {"--buttons", NULL, &buttons},
        {"--dev", &dev, NULL},
        {"--prime", &prime, NULL},
        {0},
    };
    parse_options(argc, argv, &o, own);
    int fd = open(dev, O_WRONLY);
    if (fd < 0)
        die("cannot open %s: %s", dev, strerror(errno));
    if (prime) {
        if (write_report(fd, axis(prime_volts(prime)), 0, 0) != 0)
            die("write %s: %s", dev, strerror(errno));
        return 0;
    }
    static struct pattern p;
    FILE *ends = begin_feed(&o, &p);
    if (o.when_open)
        wait_open(o.when_open, 60);
    struct hid h = {.fd = fd, .buttons = buttons, .neutral = p.neutral};
    struct play_stats st = play(&p, o.period_us, emit, &h, ends);
    print_stats(buttons ? "button reports" : "axis reports", &st, o.period_us);
    if (ends)
        fclose(ends);
    return st.stopped_by_error ? 1 : 0;
}

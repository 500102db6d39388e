/*
 * i2cfeed: plays the breath pattern into a simulated ADS1115 ADC: an
 * i2c-stub chip at 0x48 on /dev/i2c-0 with the real ti-ads1015 driver bound
 * to it (the guest script makes both). Each period it writes the chip's
 * conversion register (register 0) with raw = round(volts / scale), scale
 * read from the channel's `_scale` file (mV per LSB, as IIO gives it), so
 * that the driver's `in_voltage0_raw` × `_scale` is the pattern's level.
 *
 * The ADS1115 sends its registers big-endian; i2c-stub stores SMBus words
 * little-endian: the word is written byte-swapped.
 *
 *   i2cfeed --scale-file PATH [options] PATTERN   play the pattern
 *   i2cfeed --scale-file PATH --prime VOLTS       write one value and exit
 *     --period-us N            write period (default 1000: up to 1 kHz;
 *                              it writes as fast as it can up to that)
 *     --bus PATH, --addr N     default /dev/i2c-0, 0x48
 *     --ends FILE              log the moment each breath ends
 *     --linger                 after the pattern, keep sending its last
 *                              level until SIGTERM
 *     --fifo PRIO, --cpu N     SCHED_FIFO priority, CPU
 *     --start-when-open PATH   begin once another process has PATH open
 *     --sync-rt                then send the neutral until that process
 *                              runs a real-time thread (its control loop)
 */
#include "common.h"
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <sys/ioctl.h>

struct adc {
    int fd;
    double volts_per_lsb;
};

static int write_word(int fd, uint8_t reg, uint16_t word)
{
    union i2c_smbus_data data = {.word = word};
    struct i2c_smbus_ioctl_data args = {
        .read_write = I2C_SMBUS_WRITE, .command = reg, .size = I2C_SMBUS_WORD_DATA, .data = &data};
    return ioctl(fd, I2C_SMBUS, &args) < 0 ? -1 : 0;
}

static int emit(double volts, void *ctx)
{
    struct adc *a = ctx;
    long raw = lround(volts / a->volts_per_lsb);
    if (raw > 32767)
        raw = 32767;
    if (raw < -32768)
        raw = -32768;
    uint16_t be = (uint16_t)raw;
    uint16_t swapped = (uint16_t)((be << 8) | (be >> 8));
    return write_word(a->fd, 0x00, swapped);
}

static double read_scale(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f)
        die("cannot open the scale file %s: %s", path, strerror(errno));
    double mv;
    int ok = fscanf(f, "%lf", &mv) == 1;
    fclose(f);
    if (!ok || !(mv > 0))
        die("%s does not hold a positive scale in mV per LSB", path);
    return mv / 1000.0;
}

int main(int argc, char **argv)
{
    prog = "i2cfeed";
    const char *bus = "/dev/i2c-0", *scale_path = NULL, *ends_path = NULL, *pattern_path = NULL;
    const char *prime = NULL, *when_open = NULL;
    long addr = 0x48, period_us = 1000;
    int prio = 0, cpu = -1;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int more = i + 1 < argc;
        if (!strcmp(a, "--scale-file") && more)
            scale_path = argv[++i];
        else if (!strcmp(a, "--period-us") && more)
            period_us = parse_long(argv[++i], "--period-us", 1, 10000000);
        else if (!strcmp(a, "--bus") && more)
            bus = argv[++i];
        else if (!strcmp(a, "--addr") && more) {
            char *end;
            addr = strtol(argv[++i], &end, 0);
            if (*end || addr < 0x03 || addr > 0x77)
                die("--addr must be a 7-bit address, got \"%s\"", argv[i]);
        } else if (!strcmp(a, "--linger"))
            linger = 1;
        else if (!strcmp(a, "--sync-rt"))
            sync_rt = 1;
        else if (!strcmp(a, "--ends") && more)
            ends_path = argv[++i];
        else if (!strcmp(a, "--fifo") && more)
            prio = (int)parse_long(argv[++i], "--fifo", 0, 99);
        else if (!strcmp(a, "--cpu") && more)
            cpu = (int)parse_long(argv[++i], "--cpu", 0, 1023);
        else if (!strcmp(a, "--prime") && more)
            prime = argv[++i];
        else if (!strcmp(a, "--start-when-open") && more)
            when_open = argv[++i];
        else if (a[0] != '-' && !pattern_path)
            pattern_path = a;
        else
            die("unknown or incomplete option \"%s\" (see the comment at the top of i2cfeed.c)", a);
    }
    if (!scale_path)
        die("--scale-file is required (the channel's in_voltageN_scale)");
    struct adc adc = {.volts_per_lsb = read_scale(scale_path)};
    adc.fd = open(bus, O_RDWR);
    if (adc.fd < 0)
        die("cannot open %s: %s", bus, strerror(errno));
    /* FORCE: the ti-ads1015 driver holds the address. */
    if (ioctl(adc.fd, I2C_SLAVE_FORCE, addr) < 0)
        die("I2C_SLAVE_FORCE 0x%02lx on %s: %s", addr, bus, strerror(errno));
    if (prime) {
        char *end;
        double v = strtod(prime, &end);
        if (*end || end == prime || !(v >= 0 && v <= 5))
            die("--prime takes volts 0..5, got \"%s\"", prime);
        if (emit(v, &adc) != 0)
            die("SMBus word write to 0x%02lx: %s", addr, strerror(errno));
        printf("%s: wrote %.3f V as raw %ld (%.6f V per LSB)\n", prog, v, lround(v / adc.volts_per_lsb),
               adc.volts_per_lsb);
        return 0;
    }
    if (!pattern_path)
        die("no pattern given");
    static struct pattern p;
    load_pattern(pattern_path, &p);
    FILE *ends = open_log(ends_path);
    catch_stop_signals();
    realtime(prio, cpu);
    if (when_open)
        wait_open(when_open, 60);
    struct play_stats st = play(&p, period_us, emit, &adc, ends);
    print_stats("register writes", &st, period_us);
    if (ends)
        fclose(ends);
    return st.stopped_by_error ? 1 : 0;
}

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
    const char *bus = "/dev/i2c-0", *scale_path = NULL, *prime = NULL, *addr_text = "0x48";
    struct feed_options o = {.period_us = 1000, .min_period_us = 1, .cpu = -1};
    const struct own_option own[] = {
        {"--scale-file", &scale_path, NULL},
        {"--bus", &bus, NULL},
        {"--addr", &addr_text, NULL},
        {"--prime", &prime, NULL},
        {0},
    };
    parse_options(argc, argv, &o, own);
    char *end;
    long addr = strtol(addr_text, &end, 0);
    if (*end || end == addr_text || addr < 0x03 || addr > 0x77)
        die("--addr must be a 7-bit address, got \"%s\"", addr_text);
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
        double v = prime_volts(prime);
        if (emit(v, &adc) != 0)
            die("SMBus word write to 0x%02lx: %s", addr, strerror(errno));
        printf("%s: wrote %.3f V as raw %ld (%.6f V per LSB)\n", prog, v, lround(v / adc.volts_per_lsb),
               adc.volts_per_lsb);
        return 0;
    }
    static struct pattern p;
    FILE *ends = begin_feed(&o, &p);
    if (o.when_open)
        wait_open(o.when_open, 60);
    struct play_stats st = play(&p, o.period_us, emit, &adc, ends);
    print_stats("register writes", &st, o.period_us);
    if (ends)
        fclose(ends);
    return st.stopped_by_error ? 1 : 0;
}

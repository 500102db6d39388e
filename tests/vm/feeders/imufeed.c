/*
 * imufeed: a head-worn IMU as Linux sees one through evdev: a uinput
 * device with INPUT_PROP_ACCELEROMETER, ABS_X/Y/Z in counts per g and
 * ABS_RX/RY/RZ in counts per degree per second (their resolutions, as
 * linux/input.h defines them for accelerometers), playing a recorded
 * session in real time.
 *
 *   imufeed [options] COUNTS
 *     COUNTS            the session, one sample a line: `tick ax ay az gx gy
 *                       gz` (tick in ms from the start; the six as counts,
 *                       made by tests/vm/run.sh from an IMU CSV)
 *     --name NAME       the device's name (default "sipnpuff test IMU")
 *     --unplug-at MS    remove the device at this ms of the session
 *                       (UI_DEV_DESTROY, or the BMI160 deleted from its
 *                       bus: the reader's next read fails with ENODEV)
 *                       and end
 *     --hold-s S        after the last sample, keep the device (holding it)
 *                       for S s before removing it (default 0.5)
 *     --sync-rt         wait for a process to open the device and for its
 *                       control loop (a SCHED_FIFO thread) to run before
 *                       playing
 *     --fifo PRIO, --cpu N   SCHED_FIFO priority, CPU
 *
 *   imufeed --bmi160 BUS [options] COUNTS
 *     The IMU is a BMI160 on i2c-stub (BUS: /dev/i2c-N, address 0x68) with
 *     the kernel's bmi160 driver bound: each sample is written to its data
 *     registers (0x0C-0x17: gyro x, y, z then accel x, y, z, little-endian
 *     16-bit) in one I2C block write. COUNTS are in the BMI160's units at
 *     the ranges --prime sets (±4 g, ±500 °/s).
 *     --prime           write the chip id (0xD1), the ranges and the first
 *                       sample, before the driver is bound, and exit
 *     --start-when-open PATH   with --sync-rt: the file the reader opens
 *                       (a channel's in_*_raw, or /dev/iio:deviceN)
 *
 * The first sample is the device's state from its creation (a reader that
 * opens it reads a head at rest, not zeros). Each sample is one frame of
 * EV_ABS events closed by SYN_REPORT, at its tick on absolute deadlines;
 * a feeder late by a sample's period sends the sample due now. Prints one
 * line at the end: `imufeed: samples N late L seconds S unplugged yes|no`.
 */
#include "common.h"
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <linux/input.h>
#include <linux/uinput.h>
#include <sys/ioctl.h>

#define MAX_SAMPLES 200000
#define ACCEL_PER_G 4096
#define GYRO_PER_DPS 1000

struct sample {
    long tick;
    int v[6];
};

static struct sample samples[MAX_SAMPLES];

static int load(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f)
        die("cannot open %s: %s", path, strerror(errno));
    int n = 0;
    char line[256];
    int lineno = 0;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        struct sample s;
        char extra;
        int got = sscanf(line, "%ld %d %d %d %d %d %d %c", &s.tick, &s.v[0], &s.v[1], &s.v[2],
                         &s.v[3], &s.v[4], &s.v[5], &extra);
        if (got <= 0)
            continue;
        if (got != 7 || s.tick < 0 || (n > 0 && s.tick <= samples[n - 1].tick))
            die("%s line %d: expected `tick ax ay az gx gy gz` (counts, ticks increasing)", path,
                lineno);
        if (n == MAX_SAMPLES)
            die("%s: more than %d samples", path, MAX_SAMPLES);
        samples[n++] = s;
    }
    fclose(f);
    if (n == 0)
        die("%s: no sample", path);
    return n;
}

static void emit(int fd, int type, int code, int value)
{
    struct input_event e;
    memset(&e, 0, sizeof e);
    e.type = type;
    e.code = code;
    e.value = value;
    if (write(fd, &e, sizeof e) != (ssize_t)sizeof e)
        die("write to /dev/uinput: %s", strerror(errno));
}

#define BMI160_ADDR 0x68
#define BMI160_DATA_GYRO_X 0x0C
#define BMI160_ACCEL_RANGE_4G_REG 0x41
#define BMI160_GYRO_RANGE_500DPS_REG 0x43

static int smbus(int fd, int size, uint8_t reg, union i2c_smbus_data *data)
{
    struct i2c_smbus_ioctl_data args = {
        .read_write = I2C_SMBUS_WRITE, .command = reg, .size = size, .data = data};
    return ioctl(fd, I2C_SMBUS, &args) < 0 ? -1 : 0;
}

/* One sample into the BMI160's data registers: gyro then accel. */
static void bmi160_frame(int fd, const struct sample *s)
{
    union i2c_smbus_data data;
    data.block[0] = 12;
    static const int order[6] = {3, 4, 5, 0, 1, 2};
    for (int k = 0; k < 6; k++) {
        uint16_t v = (uint16_t)(int16_t)s->v[order[k]];
        data.block[1 + 2 * k] = (uint8_t)(v & 0xff);
        data.block[2 + 2 * k] = (uint8_t)(v >> 8);
    }
    if (smbus(fd, I2C_SMBUS_I2C_BLOCK_DATA, BMI160_DATA_GYRO_X, &data) != 0)
        die("I2C block write to the BMI160's data registers: %s", strerror(errno));
}

/* The registers its driver reads at probe: chip id, ±4 g, ±500 °/s. */
static void bmi160_prime(int fd, const struct sample *first)
{
    static const uint8_t regs[3][2] = {{0x00, 0xD1}, {BMI160_ACCEL_RANGE_4G_REG, 0x05},
                                       {BMI160_GYRO_RANGE_500DPS_REG, 0x02}};
    for (int k = 0; k < 3; k++) {
        union i2c_smbus_data data = {.byte = regs[k][1]};
        if (smbus(fd, I2C_SMBUS_BYTE_DATA, regs[k][0], &data) != 0)
            die("SMBus write of register 0x%02x: %s", regs[k][0], strerror(errno));
    }
    bmi160_frame(fd, first);
}

static int bmi160_bus = -1; /* the bus's fd in --bmi160 mode */

/* The BMI160 removed from its bus (/dev/i2c-N's delete_device), as if
 * unplugged: its IIO device goes, and its reader's next read fails. */
static void bmi160_unbind(const char *bus)
{
    const char *n = strrchr(bus, '-');
    char path[128];
    snprintf(path, sizeof path, "/sys/bus/i2c/devices/i2c-%s/delete_device", n ? n + 1 : "0");
    int f = open(path, O_WRONLY);
    if (f < 0 || dprintf(f, "0x%02x\n", BMI160_ADDR) < 0)
        die("cannot write %s: %s", path, strerror(errno));
    close(f);
}

static void frame(int fd, const struct sample *s)
{
    if (bmi160_bus >= 0) {
        bmi160_frame(bmi160_bus, s);
        return;
    }
    static const int codes[6] = {ABS_X, ABS_Y, ABS_Z, ABS_RX, ABS_RY, ABS_RZ};
    for (int k = 0; k < 6; k++)
        emit(fd, EV_ABS, codes[k], s->v[k]);
    emit(fd, EV_SYN, SYN_REPORT, 0);
}

/* The event node of the uinput device `fd` (/dev/input/eventN). */
static void event_node(int fd, char *out, size_t size)
{
    char sysname[64];
    if (ioctl(fd, UI_GET_SYSNAME(sizeof sysname), sysname) < 0)
        die("UI_GET_SYSNAME: %s", strerror(errno));
    char dir[128];
    snprintf(dir, sizeof dir, "/sys/devices/virtual/input/%s", sysname);
    for (int tries = 0; tries < 500; tries++) {
        DIR *d = opendir(dir);
        if (d) {
            struct dirent *e;
            while ((e = readdir(d))) {
                if (!strncmp(e->d_name, "event", 5)) {
                    snprintf(out, size, "/dev/input/%s", e->d_name);
                    closedir(d);
                    if (access(out, R_OK) == 0)
                        return;
                    d = NULL;
                    break;
                }
            }
            if (d)
                closedir(d);
        }
        usleep(2000);
    }
    die("no event node under %s", dir);
}

int main(int argc, char **argv)
{
    prog = "imufeed";
    const char *name = "sipnpuff test IMU", *path = NULL, *bus = NULL, *opened = NULL;
    long unplug_at = -1, hold_ms = 500;
    int prio = 0, cpu = -1, sync = 0, prime = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--name") && i + 1 < argc)
            name = argv[++i];
        else if (!strcmp(a, "--unplug-at") && i + 1 < argc)
            unplug_at = parse_long(argv[++i], a, 0, 86400000);
        else if (!strcmp(a, "--hold-s") && i + 1 < argc)
            hold_ms = parse_long(argv[++i], a, 0, 3600) * 1000;
        else if (!strcmp(a, "--fifo") && i + 1 < argc)
            prio = (int)parse_long(argv[++i], a, 0, 99);
        else if (!strcmp(a, "--cpu") && i + 1 < argc)
            cpu = (int)parse_long(argv[++i], a, 0, 1023);
        else if (!strcmp(a, "--sync-rt"))
            sync = 1;
        else if (!strcmp(a, "--bmi160") && i + 1 < argc)
            bus = argv[++i];
        else if (!strcmp(a, "--prime"))
            prime = 1;
        else if (!strcmp(a, "--start-when-open") && i + 1 < argc)
            opened = argv[++i];
        else if (a[0] != '-' && !path)
            path = a;
        else
            die("unknown argument %s", a);
    }
    if (!path)
        die("usage: imufeed [--name NAME | --bmi160 BUS [--prime] [--start-when-open PATH]] [--unplug-at MS] [--hold-s S] [--sync-rt] [--fifo P] [--cpu N] COUNTS");
    int n = load(path);
    int fd = -1;
    char node[PATH_MAX];
    if (bus) {
        bmi160_bus = open(bus, O_RDWR);
        if (bmi160_bus < 0)
            die("cannot open %s: %s", bus, strerror(errno));
        /* FORCE: the bmi160 driver holds the address. */
        if (ioctl(bmi160_bus, I2C_SLAVE_FORCE, BMI160_ADDR) < 0)
            die("I2C_SLAVE_FORCE 0x%02x on %s: %s", BMI160_ADDR, bus, strerror(errno));
        if (prime) {
            bmi160_prime(bmi160_bus, &samples[0]);
            printf("imufeed: BMI160 at 0x%02x on %s primed\n", BMI160_ADDR, bus);
            return 0;
        }
        if (sync && !opened)
            die("--sync-rt with --bmi160 needs --start-when-open PATH");
        bmi160_frame(bmi160_bus, &samples[0]);
        snprintf(node, sizeof node, "%s", opened ? opened : bus);
    } else {
        fd = open("/dev/uinput", O_WRONLY);
        if (fd < 0)
            die("cannot open /dev/uinput: %s", strerror(errno));
        if (ioctl(fd, UI_SET_PROPBIT, INPUT_PROP_ACCELEROMETER) < 0 || ioctl(fd, UI_SET_EVBIT, EV_ABS) < 0)
            die("UI_SET_PROPBIT/EVBIT: %s", strerror(errno));
        static const int codes[6] = {ABS_X, ABS_Y, ABS_Z, ABS_RX, ABS_RY, ABS_RZ};
        for (int k = 0; k < 6; k++) {
            struct uinput_abs_setup abs;
            memset(&abs, 0, sizeof abs);
            abs.code = codes[k];
            abs.absinfo.minimum = k < 3 ? -16 * ACCEL_PER_G : -2000 * GYRO_PER_DPS;
            abs.absinfo.maximum = k < 3 ? 16 * ACCEL_PER_G : 2000 * GYRO_PER_DPS;
            abs.absinfo.resolution = k < 3 ? ACCEL_PER_G : GYRO_PER_DPS;
            abs.absinfo.value = samples[0].v[k];
            if (ioctl(fd, UI_SET_ABSBIT, codes[k]) < 0 || ioctl(fd, UI_ABS_SETUP, &abs) < 0)
                die("UI_ABS_SETUP %d: %s", codes[k], strerror(errno));
        }
        struct uinput_setup setup;
        memset(&setup, 0, sizeof setup);
        setup.id.bustype = BUS_VIRTUAL;
        setup.id.vendor = 0x1d6b;
        setup.id.product = 0x0105;
        snprintf(setup.name, sizeof setup.name, "%s", name);
        if (ioctl(fd, UI_DEV_SETUP, &setup) < 0 || ioctl(fd, UI_DEV_CREATE) < 0)
            die("UI_DEV_SETUP/CREATE: %s", strerror(errno));
        event_node(fd, node, sizeof node);
        fprintf(stderr, "imufeed: %s is %s, %d samples\n", name, node, n);
    }
    realtime(prio, cpu);
    if (sync) {
        wait_open(node, 60);
        int64_t deadline = mono_ns() + 60000000000LL;
        while (!rt_thread(opener_pid)) {
            if (mono_ns() > deadline)
                die("pid %d opened %s but ran no SCHED_FIFO thread within 60 s", (int)opener_pid, node);
            usleep(5000);
        }
    }

    int64_t start = mono_ns();
    long late = 0;
    int unplugged = 0;
    int i = 1;
    while (i < n) {
        if (unplug_at >= 0 && samples[i].tick >= unplug_at) {
            sleep_until_ns(start + (int64_t)unplug_at * 1000000LL);
            if (fd >= 0)
                ioctl(fd, UI_DEV_DESTROY);
            else
                bmi160_unbind(bus);
            unplugged = 1;
            break;
        }
        sleep_until_ns(start + (int64_t)samples[i].tick * 1000000LL);
        /* Late by more than a sample's period: send the sample due now. */
        long now_ms = (long)((mono_ns() - start) / 1000000LL);
        while (i + 1 < n && samples[i + 1].tick <= now_ms) {
            i++;
            late++;
        }
        frame(fd, &samples[i]);
        i++;
    }
    double seconds = (double)(mono_ns() - start) / 1e9;
    /* Said before the hold: a test may end the feeder during it. */
    printf("imufeed: samples %d late %ld seconds %.3f unplugged %s\n", i, late, seconds,
           unplugged ? "yes" : "no");
    fflush(stdout);
    if (!unplugged) {
        /* Held (the reader's last frames read, its run ended), then gone. */
        usleep((useconds_t)hold_ms * 1000);
        if (fd >= 0)
            ioctl(fd, UI_DEV_DESTROY);
    }
    close(fd >= 0 ? fd : bmi160_bus);
    return 0;
}

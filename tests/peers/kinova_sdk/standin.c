/*
 * A stand-in for Kinova's JACO2 command layer (Kinova.API.USBCommandLayerUbuntu.so
 * and Kinova.API.EthCommandLayerUbuntu.so), for sipnpuff's tests. Written here from
 * the C declarations in Kinova's SDK 5.03 headers as kinova-ros ships them
 * (kinova_driver/include/kinova/KinovaTypes.h, Kinova.API.USBCommandLayerUbuntu.h,
 * Kinova.API.USBCommLayerUbuntu.h): the same structures, the same exported names
 * (the Ethernet layer's with the `Ethernet_` prefix: build with -DSTANDIN_ETHERNET),
 * the same arguments (C++ references are pointers in the ABI). It proves the calls
 * and values a client makes, NOT the real library's behaviour.
 *
 * It records every call, one line each, to the file named by KINOVA_STANDIN_LOG:
 *   <CLOCK_MONOTONIC ns> <exported name> key=value ...
 * and integrates each CARTESIAN_VELOCITY point over one 10 ms DSP cycle into a pose,
 * which GetCartesianPosition returns (X, Y, Z in m; ThetaX, ThetaY, ThetaZ in rad,
 * Euler XYZ: R = Rx(ThetaX) Ry(ThetaY) Rz(ThetaZ)).
 *
 * Told to fail by environment variables:
 *   KINOVA_STANDIN_INIT_CODE=N          InitAPI/InitEthernetAPI returns N
 *   KINOVA_STANDIN_INIT_DELAY_MS=N      InitAPI/InitEthernetAPI sleeps N ms first
 *   KINOVA_STANDIN_DEVICES=N            GetDevices finds N arms (default 1)
 *   KINOVA_STANDIN_FAIL_SEND_AFTER=N    SendAdvanceTrajectory fails from call N+1 on
 *   KINOVA_STANDIN_FAIL_MOVING_AFTER=N  ... fails from the (N+1)th point that moves (not zero) on
 *   KINOVA_STANDIN_FAIL_CODE=N          ... with code N (default 1015)
 *   KINOVA_STANDIN_HANG_SEND_AFTER=N    call N+1 of SendAdvanceTrajectory never returns
 *   KINOVA_STANDIN_POSE=x,y,z,tx,ty,tz  the starting pose (default 0.21,-0.26,0.48,0,0,0)
 * and at build time: -DSTANDIN_OMIT_SEND leaves SendAdvanceTrajectory out (a library
 * missing a symbol).
 */
#define _GNU_SOURCE
#include <math.h>
#include <stdarg.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#ifdef STANDIN_ETHERNET
#define API(name) Ethernet_##name
#else
#define API(name) name
#endif
#define EXPORT __attribute__((visibility("default")))

/* ---- KinovaTypes.h / the comm layer's header, as declared there ---- */

enum POSITION_TYPE { NOMOVEMENT_POSITION = 0, CARTESIAN_POSITION = 1, CARTESIAN_VELOCITY = 7 };
enum HAND_MODE { HAND_NOMOVEMENT, POSITION_MODE, VELOCITY_MODE };

typedef struct { float X, Y, Z, ThetaX, ThetaY, ThetaZ; } CartesianInfo;
typedef struct { float Actuator1, Actuator2, Actuator3, Actuator4, Actuator5, Actuator6, Actuator7; } AngularInfo;
typedef struct { float Finger1, Finger2, Finger3; } FingersPosition;
typedef struct { CartesianInfo Coordinates; FingersPosition Fingers; } CartesianPosition;
typedef struct {
    enum POSITION_TYPE Type;
    float Delay;
    CartesianInfo CartesianPosition;
    AngularInfo Actuators;
    enum HAND_MODE HandMode;
    FingersPosition Fingers;
} UserPosition;
typedef struct {
    float speedParameter1, speedParameter2, speedParameter3;
    float forceParameter1, forceParameter2, forceParameter3;
    float accelerationParameter1, accelerationParameter2, accelerationParameter3;
} Limitation;
typedef struct {
    UserPosition Position;
    int LimitationsActive;
    int SynchroType;
    Limitation Limitations;
} TrajectoryPoint;

#define SERIAL_LENGTH 20
#define MAX_KINOVA_DEVICE 20
typedef struct {
    char SerialNumber[SERIAL_LENGTH];
    char Model[SERIAL_LENGTH];
    int VersionMajor, VersionMinor, VersionRelease;
    int DeviceType;
    int DeviceID;
} KinovaDevice;

typedef struct {
    unsigned long localIpAddress;
    unsigned long subnetMask;
    unsigned long robotIpAddress;
    unsigned short localCmdport;
    unsigned short localBcastPort;
    unsigned short robotPort;
    unsigned long rxTimeOutInMs;
} EthernetCommConfig;

#define NO_ERROR_KINOVA 1
#define ERROR_NO_DEVICE_FOUND 1015
#define ERROR_API_NOT_INITIALIZED 2101

/* ---- state ---- */

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static FILE *log_file;
static int initialized, controlling, cartesian;
static long sends __attribute__((unused));
static long moving_sends __attribute__((unused));
static int failing __attribute__((unused));
static double position[3] = {0.21, -0.26, 0.48};
static double rotation[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
static double fingers;

static long env_long(const char *name, long fallback) {
    const char *text = getenv(name);
    return text && *text ? strtol(text, NULL, 10) : fallback;
}

static unsigned long long now_ns(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (unsigned long long)t.tv_sec * 1000000000ull + (unsigned long long)t.tv_nsec;
}

/* One line: the time, the exported name, then the caller's fields. */
static void record(const char *name, const char *format, ...) __attribute__((format(printf, 2, 3)));
static void record(const char *name, const char *format, ...) {
    if (!log_file) {
        const char *path = getenv("KINOVA_STANDIN_LOG");
        log_file = fopen(path && *path ? path : "/dev/null", "a");
        if (!log_file) return;
    }
    fprintf(log_file, "%llu %s", now_ns(), name);
    if (*format) {
        va_list args;
        fputc(' ', log_file);
        va_start(args, format);
        vfprintf(log_file, format, args);
        va_end(args);
    }
    fputc('\n', log_file);
    fflush(log_file);
}

static void matmul(double a[3][3], double b[3][3], double out[3][3]) {
    double r[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
    memcpy(out, r, sizeof r);
}

/* Rx(tx) Ry(ty) Rz(tz). */
static void from_euler_xyz(double tx, double ty, double tz, double out[3][3]) {
    double rx[3][3] = {{1, 0, 0}, {0, cos(tx), -sin(tx)}, {0, sin(tx), cos(tx)}};
    double ry[3][3] = {{cos(ty), 0, sin(ty)}, {0, 1, 0}, {-sin(ty), 0, cos(ty)}};
    double rz[3][3] = {{cos(tz), -sin(tz), 0}, {sin(tz), cos(tz), 0}, {0, 0, 1}};
    matmul(rx, ry, out);
    matmul(out, rz, out);
}

static void to_euler_xyz(double r[3][3], double *tx, double *ty, double *tz) {
    double s = r[0][2] > 1 ? 1 : (r[0][2] < -1 ? -1 : r[0][2]);
    *tx = atan2(-r[1][2], r[2][2]);
    *ty = asin(s);
    *tz = atan2(-r[0][1], r[0][0]);
}

/* The rotation by the vector w (rad), Rodrigues. */
__attribute__((unused)) static void rotation_of(const double w[3], double out[3][3]) {
    double angle = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    double k[3] = {0, 0, 0};
    if (angle > 0) {
        k[0] = w[0] / angle;
        k[1] = w[1] / angle;
        k[2] = w[2] / angle;
    }
    double c = cos(angle), s = sin(angle), v = 1 - c;
    double r[3][3] = {
        {c + k[0] * k[0] * v, k[0] * k[1] * v - k[2] * s, k[0] * k[2] * v + k[1] * s},
        {k[1] * k[0] * v + k[2] * s, c + k[1] * k[1] * v, k[1] * k[2] * v - k[0] * s},
        {k[2] * k[0] * v - k[1] * s, k[2] * k[1] * v + k[0] * s, c + k[2] * k[2] * v},
    };
    memcpy(out, r, sizeof r);
}

__attribute__((constructor)) static void start(void) {
    const char *pose = getenv("KINOVA_STANDIN_POSE");
    double p[6] = {0.21, -0.26, 0.48, 0, 0, 0};
    if (pose && *pose)
        sscanf(pose, "%lf,%lf,%lf,%lf,%lf,%lf", &p[0], &p[1], &p[2], &p[3], &p[4], &p[5]);
    memcpy(position, p, sizeof position);
    from_euler_xyz(p[3], p[4], p[5], rotation);
}

static int init_common(const char *name, const char *extra) {
    long delay = env_long("KINOVA_STANDIN_INIT_DELAY_MS", 0);
    if (delay > 0) usleep((useconds_t)delay * 1000);
    int code = (int)env_long("KINOVA_STANDIN_INIT_CODE", NO_ERROR_KINOVA);
    record(name,
           "%ssizeof_trajectory_point=%zu sizeof_user_position=%zu sizeof_cartesian_position=%zu "
           "sizeof_kinova_device=%zu sizeof_ethernet_comm_config=%zu offset_limitations=%zu "
           "offset_hand_mode=%zu returns=%d",
           extra, sizeof(TrajectoryPoint), sizeof(UserPosition), sizeof(CartesianPosition),
           sizeof(KinovaDevice), sizeof(EthernetCommConfig),
           __builtin_offsetof(TrajectoryPoint, Limitations),
           __builtin_offsetof(UserPosition, HandMode), code);
    if (code == NO_ERROR_KINOVA) initialized = 1;
    return code;
}

/* ---- the API ---- */

EXPORT int API(InitAPI)(void) {
    pthread_mutex_lock(&lock);
    int code = init_common(__func__, "");
    pthread_mutex_unlock(&lock);
    return code;
}

static void ip_text(unsigned long address, char *out, size_t size) {
    unsigned char b[4];
    unsigned int a = (unsigned int)address; /* network order, as inet_addr gives it */
    memcpy(b, &a, 4);
    snprintf(out, size, "%u.%u.%u.%u", b[0], b[1], b[2], b[3]);
}

EXPORT int API(InitEthernetAPI)(EthernetCommConfig *config) {
    char local[32], mask[32], robot[32], extra[256];
    ip_text(config->localIpAddress, local, sizeof local);
    ip_text(config->subnetMask, mask, sizeof mask);
    ip_text(config->robotIpAddress, robot, sizeof robot);
    snprintf(extra, sizeof extra,
             "local_ip=%s subnet_mask=%s robot_ip=%s robot_port=%u local_cmd_port=%u "
             "local_broadcast_port=%u rx_timeout_ms=%lu ",
             local, mask, robot, config->robotPort, config->localCmdport, config->localBcastPort,
             config->rxTimeOutInMs);
    pthread_mutex_lock(&lock);
    int code = init_common(__func__, extra);
    pthread_mutex_unlock(&lock);
    return code;
}

EXPORT int API(CloseAPI)(void) {
    pthread_mutex_lock(&lock);
    int code = initialized ? NO_ERROR_KINOVA : ERROR_API_NOT_INITIALIZED;
    initialized = controlling = cartesian = 0;
    record(__func__, "returns=%d", code);
    pthread_mutex_unlock(&lock);
    return code;
}

EXPORT int API(GetDevices)(KinovaDevice devices[MAX_KINOVA_DEVICE], int *result) {
    pthread_mutex_lock(&lock);
    long count = initialized ? env_long("KINOVA_STANDIN_DEVICES", 1) : 0;
    if (count > MAX_KINOVA_DEVICE) count = MAX_KINOVA_DEVICE;
    for (long i = 0; i < count; i++) {
        memset(&devices[i], 0, sizeof devices[i]);
        snprintf(devices[i].SerialNumber, SERIAL_LENGTH, "PJ0000000%ld", i + 1);
        snprintf(devices[i].Model, SERIAL_LENGTH, "JACO2 standin");
        devices[i].VersionMajor = 6;
        devices[i].DeviceID = (int)i;
    }
    *result = initialized ? NO_ERROR_KINOVA : ERROR_API_NOT_INITIALIZED;
    record(__func__, "count=%ld result=%d", count, *result);
    pthread_mutex_unlock(&lock);
    return (int)count;
}

EXPORT int API(SetActiveDevice)(KinovaDevice device) {
    pthread_mutex_lock(&lock);
    int code = initialized ? NO_ERROR_KINOVA : ERROR_API_NOT_INITIALIZED;
    char serial[SERIAL_LENGTH + 1] = {0};
    memcpy(serial, device.SerialNumber, SERIAL_LENGTH);
    record(__func__, "serial=%s device_id=%d returns=%d", serial, device.DeviceID, code);
    pthread_mutex_unlock(&lock);
    return code;
}

EXPORT int API(RefresDevicesList)(void) {
    pthread_mutex_lock(&lock);
    record(__func__, "returns=%d", NO_ERROR_KINOVA);
    pthread_mutex_unlock(&lock);
    return NO_ERROR_KINOVA;
}

/* A call that needs InitAPI first and then sets the state `flag` points to
 * (if any) to `value`: records its return code and returns it. */
static int state_call(const char *name, int *flag, int value) {
    pthread_mutex_lock(&lock);
    int code = initialized ? NO_ERROR_KINOVA : ERROR_API_NOT_INITIALIZED;
    if (initialized && flag) *flag = value;
    record(name, "returns=%d", code);
    pthread_mutex_unlock(&lock);
    return code;
}

EXPORT int API(StartControlAPI)(void) { return state_call(__func__, &controlling, 1); }
EXPORT int API(StopControlAPI)(void) { return state_call(__func__, &controlling, 0); }
EXPORT int API(SetCartesianControl)(void) { return state_call(__func__, &cartesian, 1); }
EXPORT int API(EraseAllTrajectories)(void) { return state_call(__func__, NULL, 0); }

#ifndef STANDIN_OMIT_SEND
EXPORT int API(SendAdvanceTrajectory)(TrajectoryPoint point) {
    pthread_mutex_lock(&lock);
    sends++;
    long fail_after = env_long("KINOVA_STANDIN_FAIL_SEND_AFTER", -1);
    long fail_moving_after = env_long("KINOVA_STANDIN_FAIL_MOVING_AFTER", -1);
    long hang_after = env_long("KINOVA_STANDIN_HANG_SEND_AFTER", -1);
    UserPosition *p = &point.Position;
    CartesianInfo *c = &p->CartesianPosition;
    int moving = c->X != 0 || c->Y != 0 || c->Z != 0 || c->ThetaX != 0 || c->ThetaY != 0 ||
                 c->ThetaZ != 0 || p->Fingers.Finger1 != 0 || p->Fingers.Finger2 != 0 ||
                 p->Fingers.Finger3 != 0;
    if (moving) moving_sends++;
    if (fail_after >= 0 && sends > fail_after) failing = 1;
    if (fail_moving_after >= 0 && moving_sends > fail_moving_after) failing = 1;
    int code = NO_ERROR_KINOVA;
    if (!initialized)
        code = ERROR_API_NOT_INITIALIZED;
    else if (failing)
        code = (int)env_long("KINOVA_STANDIN_FAIL_CODE", ERROR_NO_DEVICE_FOUND);
    AngularInfo *a = &p->Actuators;
    Limitation *l = &point.Limitations;
    record(__func__,
           "n=%ld type=%d delay=%.9g x=%.9g y=%.9g z=%.9g tx=%.9g ty=%.9g tz=%.9g "
           "actuators=%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g hand_mode=%d f1=%.9g f2=%.9g f3=%.9g "
           "limitations_active=%d synchro=%d limitations=%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g "
           "control=%d cartesian=%d returns=%d",
           sends, (int)p->Type, p->Delay, c->X, c->Y, c->Z, c->ThetaX, c->ThetaY, c->ThetaZ,
           a->Actuator1, a->Actuator2, a->Actuator3, a->Actuator4, a->Actuator5, a->Actuator6,
           a->Actuator7, (int)p->HandMode, p->Fingers.Finger1, p->Fingers.Finger2,
           p->Fingers.Finger3, point.LimitationsActive, point.SynchroType, l->speedParameter1,
           l->speedParameter2, l->speedParameter3, l->forceParameter1, l->forceParameter2,
           l->forceParameter3, l->accelerationParameter1, l->accelerationParameter2,
           l->accelerationParameter3, controlling, cartesian, code);
    if (hang_after >= 0 && sends > hang_after) {
        pthread_mutex_unlock(&lock);
        for (;;) pause();
    }
    if (code == NO_ERROR_KINOVA && controlling && p->Type == CARTESIAN_VELOCITY) {
        /* One point is one 10 ms DSP cycle. */
        const double dt = 0.010;
        position[0] += c->X * dt;
        position[1] += c->Y * dt;
        position[2] += c->Z * dt;
        double w[3] = {c->ThetaX * dt, c->ThetaY * dt, c->ThetaZ * dt}, step[3][3];
        rotation_of(w, step);
        matmul(step, rotation, rotation);
        if (p->HandMode == VELOCITY_MODE) {
            fingers += p->Fingers.Finger1 * dt;
            if (fingers < 0) fingers = 0;
            if (fingers > 6800) fingers = 6800;
        }
    }
    pthread_mutex_unlock(&lock);
    return code;
}
#endif

EXPORT int API(GetCartesianPosition)(CartesianPosition *response) {
    pthread_mutex_lock(&lock);
    int code = initialized ? NO_ERROR_KINOVA : ERROR_API_NOT_INITIALIZED;
    double tx, ty, tz;
    to_euler_xyz(rotation, &tx, &ty, &tz);
    response->Coordinates.X = (float)position[0];
    response->Coordinates.Y = (float)position[1];
    response->Coordinates.Z = (float)position[2];
    response->Coordinates.ThetaX = (float)tx;
    response->Coordinates.ThetaY = (float)ty;
    response->Coordinates.ThetaZ = (float)tz;
    response->Fingers.Finger1 = response->Fingers.Finger2 = response->Fingers.Finger3 = (float)fingers;
    CartesianInfo *c = &response->Coordinates;
    record(__func__, "x=%.9g y=%.9g z=%.9g tx=%.9g ty=%.9g tz=%.9g f1=%.9g returns=%d", c->X, c->Y,
           c->Z, c->ThetaX, c->ThetaY, c->ThetaZ, response->Fingers.Finger1, code);
    pthread_mutex_unlock(&lock);
    return code;
}

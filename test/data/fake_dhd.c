/* A stand-in for the Force Dimension SDK's libdhd, built by test/unit/test_haptics_dhd.py: the same C functions
 * (dhdc.h signatures) that teleteach's dhd backend calls, so the ctypes bindings run against real C code.
 * FAKE_DHD_DEVICES=0 simulates "no device plugged in"; FAKE_DHD_FAIL_READS=1 makes reads fail.
 * The device sits at (0.01, 0.02, 0.03) m, yawed by 0.5 rad, gripper at 0.3 rad, button pressed.
 * It records what it receives: the force enable state and the last force, torque and gripper force
 * (fakeDhdReceived, not part of the SDK, lets the test read them back), and how many force commands came.
 * FAKE_DHD_RECORD=<path> also appends every force command to that file, one line of 7 numbers (fx fy fz tx ty tz fg),
 * so a test can read what a node in another process sent. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *last_error = "no error";
static int opened = 0;
static int forces_enabled = 0;
static int force_commands = 0;
static double received[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
static FILE *record = NULL;

static int flag(const char *name, int fallback) {
  const char *value = getenv(name);
  return value ? atoi(value) : fallback;
}

int dhdOpen(void) {
  if (!flag("FAKE_DHD_DEVICES", 1)) {
    last_error = "no device found";
    return -1;
  }
  opened = 1;
  return 0;
}

int dhdClose(char id) {
  (void)id;
  opened = 0;
  if (record) {
    fclose(record);
    record = NULL;
  }
  return 0;
}

int dhdGetPositionAndOrientationFrame(double *px, double *py, double *pz, double matrix[3][3], char id) {
  (void)id;
  if (!opened || flag("FAKE_DHD_FAIL_READS", 0)) {
    last_error = "communication error between the host and the device";
    return -1;
  }
  *px = 0.01;
  *py = 0.02;
  *pz = 0.03;
  double c = cos(0.5), s = sin(0.5);
  double frame[3][3] = {{c, -s, 0.0}, {s, c, 0.0}, {0.0, 0.0, 1.0}};
  memcpy(matrix, frame, sizeof(frame));
  return 1; /* DHD_TIMEGUARD: a valid (cached) value */
}

int dhdGetGripperAngleRad(double *angle, char id) {
  (void)id;
  *angle = 0.3;
  return 0;
}

int dhdEmulateButton(unsigned char on, char id) {
  (void)on;
  (void)id;
  return 0;
}

int dhdGetButton(int index, char id) {
  (void)id;
  return index == 0 ? 1 : 0;
}

int dhdEnableForce(unsigned char on, char id) {
  (void)id;
  if (!opened) {
    last_error = "device not open";
    return -1;
  }
  forces_enabled = on;
  return 0;
}

int dhdSetForceAndTorqueAndGripperForce(double fx, double fy, double fz, double tx, double ty, double tz, double fg,
                                        char id) {
  (void)id;
  if (!opened || flag("FAKE_DHD_FAIL_READS", 0)) {
    last_error = "communication error between the host and the device";
    return -1;
  }
  double values[7] = {fx, fy, fz, tx, ty, tz, fg};
  memcpy(received, values, sizeof(values));
  force_commands++;
  const char *path = getenv("FAKE_DHD_RECORD");
  if (path && !record) {
    record = fopen(path, "a");
    if (record) setvbuf(record, NULL, _IOLBF, 0);
  }
  if (record) fprintf(record, "%.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", fx, fy, fz, tx, ty, tz, fg);
  return 0;
}

/* Not in the SDK: what the fake received (7 values), whether forces are enabled, and the number of commands. */
int fakeDhdReceived(double values[7], int *enabled) {
  memcpy(values, received, sizeof(received));
  *enabled = forces_enabled;
  return force_commands;
}

const char *dhdErrorGetLastStr(void) { return last_error; }

#pragma once
/// The part of Force Dimension's DHD (haptic) and DRD (robotic) C API that the `fd` backend uses
/// (docs/devices.md, "Force Dimension"), written from the SDK's documentation: the types of the
/// functions it resolves at run time, the error codes, the system types and the version the backend
/// needs. Nothing here is linked; src/device/fd_device.cpp loads the SDK with SharedLibrary. The
/// stand-in SDK of the tests (tests/device/standins/fd/) implements the same declarations.
///
/// Every function takes the device's ID (a `char`, as the SDK's headers declare it) last. Getters
/// return 0 on success, DHD_TIMEGUARD (1) or DHD_MOTOR_SATURATED (2) as harmless positive notes, and
/// a negative value on error, whose code dhdErrorGetLast() tells.

#include <array>

namespace cariesim::fd {

// Error codes (dhdErrorGetLast), in the SDK's enum order.
inline constexpr int kNoError = 0;
inline constexpr int kError = 1;
inline constexpr int kErrorCom = 2;
inline constexpr int kErrorDhcBusy = 3;
inline constexpr int kErrorNoDriverFound = 4;
inline constexpr int kErrorNoDeviceFound = 5;
inline constexpr int kErrorNotAvailable = 6;
inline constexpr int kErrorTimeout = 7;
inline constexpr int kErrorGeometry = 8;
inline constexpr int kErrorExpertModeDisabled = 9;
inline constexpr int kErrorNotImplemented = 10;
inline constexpr int kErrorOutOfMemory = 11;
inline constexpr int kErrorDeviceNotReady = 12;
inline constexpr int kErrorFileNotFound = 13;
inline constexpr int kErrorConfiguration = 14;
inline constexpr int kErrorInvalidIndex = 15;
inline constexpr int kErrorDeprecated = 16;
inline constexpr int kErrorNullArgument = 17;
inline constexpr int kErrorRedundantFail = 18;
inline constexpr int kErrorNotEnabled = 19;
inline constexpr int kErrorDeviceInUse = 20;

// Positive, non-error return values.
inline constexpr int kTimeGuard = 1;
inline constexpr int kMotorSaturated = 2;

// dhdEnableForce's argument.
inline constexpr unsigned char kOn = 1;
inline constexpr unsigned char kOff = 0;

// System types (dhdGetSystemType).
inline constexpr int kDeviceNone = 0;
inline constexpr int kDeviceOmega3 = 33;
inline constexpr int kDeviceOmega33 = 34;
inline constexpr int kDeviceOmega331 = 35;
inline constexpr int kDeviceOmega33Left = 36;
inline constexpr int kDeviceOmega331Left = 37;
inline constexpr int kDeviceFalcon = 60;
inline constexpr int kDeviceDelta3 = 63;
inline constexpr int kDeviceDelta6 = 64;
inline constexpr int kDeviceSigma331 = 104;
inline constexpr int kDeviceSigma331Left = 105;
inline constexpr int kDeviceSigma33p = 106;
inline constexpr int kDeviceSigma33pLeft = 107;
inline constexpr int kDeviceLambda331 = 108;
inline constexpr int kDeviceLambda331Left = 109;

/// The oldest SDK with every function the backend resolves: dhdSetForceAndTorqueAndGripperForce
/// came with 3.3.0 (dhdGetSystemName with 3.2).
inline constexpr std::array<int, 3> kMinimumVersion = {3, 3, 0};

// DHD: the haptic SDK (libdhd.so.3, and exported by libdrd.so.3 too).
using GetSdkVersion = void (*)(int* major, int* minor, int* release, int* revision);
using GetDeviceCount = int (*)();
using OpenId = int (*)(char id);
using OpenSerial = int (*)(int serial);
using Close = int (*)(char id);
using GetSystemType = int (*)(char id);
using GetSystemName = const char* (*)(char id);
using GetSerialNumber = int (*)(unsigned short* serial, char id);
using EnableForce = int (*)(unsigned char on, char id);
using GetPosition = int (*)(double* x, double* y, double* z, char id);
using GetOrientationFrame = int (*)(double matrix[3][3], char id);
using GetLinearVelocity = int (*)(double* vx, double* vy, double* vz, char id);
using GetAngularVelocityRad = int (*)(double* wx, double* wy, double* wz, char id);
using GetButtonMask = unsigned int (*)(char id);
using SetForceAndTorque = int (*)(double fx, double fy, double fz, double tx, double ty, double tz, char id);
using SetForceAndTorqueAndGripperForce = int (*)(double fx, double fy, double fz, double tx, double ty,
                                                 double tz, double fg, char id);
using ErrorGetLast = int (*)();
using ErrorGetLastStr = const char* (*)();

// DRD: the robotic SDK (libdrd.so.3 only): automatic initialisation (robotic homing).
using DrdOpenId = int (*)(char id);
using DrdClose = int (*)(char id);
using DrdIsInitialized = bool (*)(char id);
using DrdAutoInit = int (*)(char id);
using DrdStop = int (*)(bool keep_forces, char id);

}  // namespace cariesim::fd

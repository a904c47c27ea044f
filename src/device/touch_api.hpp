#pragma once
// The part of OpenHaptics' HD API (hd.h, hdDefines.h, hdScheduler.h) the `touch` backend uses,
// declared from the vendor's documentation: the C types, the constants and the function pointer
// types. cariesim never links libHD; it loads it at run time (device/shared_library.hpp) and resolves
// these functions by name (docs/devices.md, "Touch").

#include <climits>

namespace cariesim::hd {

// Types (hdDefines.h, hdScheduler.h).
using HDuint = unsigned int;
using HDboolean = unsigned char;
using HDulong = unsigned long;
using HDushort = unsigned short;
using HDint = int;
using HDdouble = double;
using HDlong = long;
using HDerror = unsigned int;
using HDenum = unsigned int;
using HDstring = const char*;
using HHD = unsigned int;
using HDCallbackCode = unsigned int;
using HDSchedulerHandle = unsigned long;
using HDSchedulerCallback = HDCallbackCode (*)(void* user_data);

/// What hdGetError returns: the HD_ code, the device's own code and the device it concerns.
struct HDErrorInfo {
  HDerror errorCode;
  int internalErrorCode;
  HHD hHD;
};

// Error codes.
inline constexpr HDerror kSuccess = 0x0000;
inline constexpr HDerror kInvalidEnum = 0x0100;
inline constexpr HDerror kInvalidValue = 0x0101;
inline constexpr HDerror kInvalidOperation = 0x0102;
inline constexpr HDerror kInvalidInputType = 0x0103;
inline constexpr HDerror kBadHandle = 0x0104;
inline constexpr HDerror kWarmMotors = 0x0200;
inline constexpr HDerror kExceededMaxForce = 0x0201;
inline constexpr HDerror kExceededMaxForceImpulse = 0x0202;
inline constexpr HDerror kExceededMaxVelocity = 0x0203;
inline constexpr HDerror kForceError = 0x0204;
inline constexpr HDerror kDeviceFault = 0x0300;
inline constexpr HDerror kDeviceAlreadyInitiated = 0x0301;
inline constexpr HDerror kCommError = 0x0302;
inline constexpr HDerror kCommConfigError = 0x0303;
inline constexpr HDerror kTimerError = 0x0304;
inline constexpr HDerror kIllegalBegin = 0x0400;
inline constexpr HDerror kIllegalEnd = 0x0401;
inline constexpr HDerror kFrameError = 0x0402;
inline constexpr HDerror kInvalidPriority = 0x0500;
inline constexpr HDerror kSchedulerFull = 0x0501;
inline constexpr HDerror kInvalidLicense = 0x0600;

// Parameters of hdGet* / hdSet*.
inline constexpr HDenum kCurrentButtons = 0x2000;
inline constexpr HDenum kCurrentInkwellSwitch = 0x2002;
inline constexpr HDenum kCurrentPosition = 0x2050;
inline constexpr HDenum kCurrentVelocity = 0x2051;
inline constexpr HDenum kCurrentTransform = 0x2052;
inline constexpr HDenum kCurrentAngularVelocity = 0x2053;
inline constexpr HDenum kVersion = 0x2500;
inline constexpr HDenum kDeviceModelType = 0x2501;
inline constexpr HDenum kDeviceSerialNumber = 0x2504;
inline constexpr HDenum kUsableWorkspaceDimensions = 0x2551;
inline constexpr HDenum kInputDof = 0x2553;
inline constexpr HDenum kOutputDof = 0x2554;
inline constexpr HDenum kCalibrationStyle = 0x2555;
inline constexpr HDenum kUpdateRate = 0x2600;
inline constexpr HDenum kNominalMaxStiffness = 0x2602;
inline constexpr HDenum kNominalMaxForce = 0x2603;
inline constexpr HDenum kNominalMaxContinuousForce = 0x2604;
inline constexpr HDenum kNominalMaxTorqueStiffness = 0x2620;
inline constexpr HDenum kNominalMaxTorqueForce = 0x2622;
inline constexpr HDenum kNominalMaxTorqueContinuousForce = 0x2623;
inline constexpr HDenum kCurrentForce = 0x2700;
inline constexpr HDenum kCurrentTorque = 0x2701;

// Capabilities (hdEnable / hdDisable).
inline constexpr HDenum kForceOutput = 0x4000;

// Scheduler.
inline constexpr HDushort kMaxSchedulerPriority = USHRT_MAX;
inline constexpr HDushort kDefaultSchedulerPriority = USHRT_MAX / 2;
inline constexpr HDCallbackCode kCallbackDone = 0;
inline constexpr HDCallbackCode kCallbackContinue = 1;

// Calibration.
inline constexpr HDenum kCalibrationOk = 0x5000;
inline constexpr HDenum kCalibrationNeedsUpdate = 0x5001;
inline constexpr HDenum kCalibrationNeedsManualInput = 0x5002;
inline constexpr HDint kCalibrationEncoderReset = 1 << 0;
inline constexpr HDint kCalibrationAuto = 1 << 1;
inline constexpr HDint kCalibrationInkwell = 1 << 2;

inline constexpr HHD kInvalidHandle = 0xFFFFFFFF;

// The functions (all C linkage, the default calling convention on Linux).
using InitDeviceFn = HHD (*)(HDstring config_name);
using DisableDeviceFn = void (*)(HHD device);
using MakeCurrentDeviceFn = void (*)(HHD device);
using FrameFn = void (*)(HHD device);
using GetErrorFn = HDErrorInfo (*)();
using CapabilityFn = void (*)(HDenum capability);
using GetIntegervFn = void (*)(HDenum parameter, HDint* values);
using GetDoublevFn = void (*)(HDenum parameter, HDdouble* values);
using GetStringFn = HDstring (*)(HDenum parameter);
using SetDoublevFn = void (*)(HDenum parameter, const HDdouble* values);
using CheckCalibrationFn = HDenum (*)();
using UpdateCalibrationFn = void (*)(HDenum style);
using SchedulerFn = void (*)();
using ScheduleFn = HDSchedulerHandle (*)(HDSchedulerCallback callback, void* user_data, HDushort priority);
using ScheduleSynchronousFn = void (*)(HDSchedulerCallback callback, void* user_data, HDushort priority);
using UnscheduleFn = void (*)(HDSchedulerHandle handle);
using SetSchedulerRateFn = void (*)(HDulong rate);

}  // namespace cariesim::hd

// Copyright 2026 sma_actuator developers
//
// Licensed under the Apache License, Version 2.0 (the "License");
// you may not use this file except in compliance with the License.
// You may obtain a copy of the License at
//
//     http://www.apache.org/licenses/LICENSE-2.0
//
// Unless required by applicable law or agreed to in writing, software
// distributed under the License is distributed on an "AS IS" BASIS,
// WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
// See the License for the specific language governing permissions and
// limitations under the License.

// Protocol and safety logic of the SMA actuator MCU, free of any hardware API.
//
// C++ twin of sma_actuator/hardware/mcu_core.py (the emulator runs the Python one); both
// replay the "mcu" scenarios of firmware/test_vectors.json to the same bytes.
// Safety rules:
//   - Duty frames are ignored until a valid Hello has configured the limits.
//   - A Duty frame with a channel above max_duty is rejected (kFaultRejected): the outputs
//     keep the last valid duty and the frame does not feed the watchdog.
//   - Dead-time interlock (DeadTimeInterlock, twin of sma_actuator/control/interlock.py):
//     a channel may drive only after the other has been off for dead_time_us; both
//     requested at once switches both off (kFaultInterlock).
//   - No valid Duty frame for kWatchdogUs (100 ms): both outputs off (kFaultWatchdog).
#ifndef SMA_MCU_CORE_H
#define SMA_MCU_CORE_H

#include <stddef.h>
#include <stdint.h>

#include "sma_protocol.h"

namespace sma {

const uint8_t kFwMajor = 1, kFwMinor = 0, kFwPatch = 0;
const uint32_t kTickHz = 1000000;  // ticks are microseconds (Arduino micros())

// Compile-time limits; a Hello can only tighten the duty limits.
struct FirmwareLimits {
  uint16_t max_duty = kDutyFullScale;
  uint16_t interlock_ceiling = 32768;  // highest interlock a Hello may set (0.5)
  uint32_t watchdog_us = 100000;
  uint32_t status_period_us = 100000;
  uint32_t adc_period_min_us = 1000;
  uint32_t adc_period_max_us = 1000000;
  uint8_t adc_bits = 12;
  uint32_t dead_time_us = 25000;  // interlock dead time, half the bridge's default 0.05 s
};

// "A wire may heat only when the other has had zero duty for the dead time"; requests for
// both at once apply zero to both. Times are wrapping microsecond ticks.
class DeadTimeInterlock {
 public:
  explicit DeadTimeInterlock(uint32_t dead_time_us) : dead_time_us_(dead_time_us) {}
  // Gate the requested pair; the applied pair is in a()/b(). Returns true if a requested
  // channel was held at zero.
  bool apply(uint16_t a, uint16_t b, uint32_t now_us);
  void expire(uint32_t now_us);  // forget turn-offs older than the dead time
  void reset(uint32_t now_us) { apply(0, 0, now_us); }
  uint16_t a() const { return applied_[0]; }
  uint16_t b() const { return applied_[1]; }

 private:
  uint32_t dead_time_us_;
  uint16_t applied_[2] = {0, 0};
  bool off_recent_[2] = {false, false};  // went off less than the dead time ago
  uint32_t off_since_[2] = {0, 0};
};

class McuCore {
 public:
  typedef uint16_t (*ReadAdc)(void* ctx);
  typedef void (*Transmit)(const uint8_t* data, size_t len, void* ctx);

  McuCore(ReadAdc read_adc, Transmit transmit, void* ctx, const FirmwareLimits& limits = FirmwareLimits());

  void start(uint32_t now_us);                   // at boot: sends the boot Status
  void receive(uint8_t byte, uint32_t now_us);   // every received byte
  void poll(uint32_t now_us);                    // watchdog and periodic reports, >= 1 kHz

  uint16_t pwm_a() const { return pwm_a_; }      // duty counts the outputs must apply
  uint16_t pwm_b() const { return pwm_b_; }
  uint16_t faults() const { return faults_; }

 private:
  void handle_frame(uint32_t now_us);
  void on_hello(const Hello& msg, uint32_t now_us);
  void on_duty(const Duty& msg, uint8_t seq, uint32_t now_us);
  void outputs_off(uint32_t now_us);
  void set_faults(uint16_t faults);
  void send_report(uint32_t now_us);
  void send_status(uint32_t now_us);
  void send(size_t len);

  ReadAdc read_adc_;
  Transmit transmit_;
  void* ctx_;
  FirmwareLimits limits_;
  FrameDecoder decoder_;
  uint8_t tx_[kMaxWireFrame];
  uint8_t tx_seq_ = 0;
  bool configured_ = false;
  uint16_t max_duty_ = 0, interlock_duty_ = 0;
  uint32_t adc_period_us_;
  uint16_t pwm_a_ = 0, pwm_b_ = 0;
  DeadTimeInterlock interlock_;
  uint16_t faults_ = kFaultNotConfigured, faults_latched_ = kFaultNotConfigured;
  int32_t status_faults_ = -1;  // faults as of the last Status sent; -1 forces one
  uint8_t duty_seq_ = 0;
  uint32_t rx_frames_ = 0, rx_crc_errors_ = 0, rx_framing_errors_ = 0, rx_malformed_ = 0;
  uint32_t last_duty_us_ = 0, last_report_us_ = 0, last_status_us_ = 0;
};

}  // namespace sma

#endif  // SMA_MCU_CORE_H

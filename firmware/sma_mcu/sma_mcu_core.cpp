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

// Protocol and safety logic of the SMA actuator MCU; see sma_mcu_core.h.
#include "sma_mcu_core.h"

namespace sma {

namespace {
// Wrapping uint32 difference: correct across the 71.6-minute micros() rollover.
uint32_t elapsed(uint32_t now_us, uint32_t then_us) { return now_us - then_us; }
}  // namespace

bool DeadTimeInterlock::apply(uint16_t a, uint16_t b, uint32_t now_us) {
  const uint16_t requested[2] = {a, b};
  const bool both = a > 0 && b > 0;
  for (int wire = 0; wire < 2; ++wire) {  // a heated wire that is not to heat any more goes off now
    if (applied_[wire] > 0 && (both || requested[wire] == 0)) {
      off_recent_[wire] = true;
      off_since_[wire] = now_us;
    }
  }
  expire(now_us);
  bool held = both;
  for (int wire = 0; wire < 2; ++wire) {
    applied_[wire] = 0;
    if (both || requested[wire] == 0) continue;
    if (off_recent_[1 - wire]) {
      held = true;
    } else {
      applied_[wire] = requested[wire];
    }
  }
  return held;
}

void DeadTimeInterlock::expire(uint32_t now_us) {
  for (int wire = 0; wire < 2; ++wire) {
    if (off_recent_[wire] && elapsed(now_us, off_since_[wire]) >= dead_time_us_) off_recent_[wire] = false;
  }
}

McuCore::McuCore(ReadAdc read_adc, Transmit transmit, void* ctx, const FirmwareLimits& limits)
    : read_adc_(read_adc), transmit_(transmit), ctx_(ctx), limits_(limits),
      adc_period_us_(limits.adc_period_max_us), interlock_(limits.dead_time_us) {}

void McuCore::start(uint32_t now_us) {
  last_duty_us_ = last_report_us_ = now_us;
  send_status(now_us);
}

void McuCore::receive(uint8_t byte, uint32_t now_us) {
  switch (decoder_.push(byte)) {
    case kNone:
      return;
    case kErrCrc:
      ++rx_crc_errors_;
      return;
    case kErrOversize:
    case kErrCobs:
    case kErrShort:
      ++rx_framing_errors_;
      return;
    case kFrameOk:
      ++rx_frames_;
      handle_frame(now_us);
      if (faults_ != status_faults_) send_status(now_us);
      return;
  }
}

void McuCore::poll(uint32_t now_us) {
  interlock_.expire(now_us);
  if (configured_ && !(faults_ & kFaultWatchdog) && elapsed(now_us, last_duty_us_) >= limits_.watchdog_us) {
    outputs_off(now_us);
    set_faults(faults_ | kFaultWatchdog);
  }
  if (configured_ && elapsed(now_us, last_report_us_) >= adc_period_us_) send_report(now_us);
  if (faults_ != status_faults_ || elapsed(now_us, last_status_us_) >= limits_.status_period_us) {
    send_status(now_us);
  }
}

void McuCore::handle_frame(uint32_t now_us) {
  const uint8_t* body = decoder_.body();
  size_t len = decoder_.body_len();
  Hello hello;
  Duty duty;
  Heartbeat heartbeat;
  if (decoder_.type() == kHello && decode(body, len, &hello)) {
    on_hello(hello, now_us);
  } else if (decoder_.type() == kDuty && decode(body, len, &duty)) {
    on_duty(duty, decoder_.seq(), now_us);
  } else if (decoder_.type() == kHeartbeat && decode(body, len, &heartbeat)) {
    HeartbeatAck ack = {heartbeat.host_us, now_us};
    send(encode(ack, tx_seq_, tx_));
  } else {
    ++rx_malformed_;
  }
}

void McuCore::on_hello(const Hello& msg, uint32_t now_us) {
  outputs_off(now_us);
  if (msg.protocol_version != kProtocolVersion) {
    configured_ = false;
    set_faults(kFaultNotConfigured | kFaultBadVersion);
  } else {
    configured_ = true;
    max_duty_ = msg.max_duty < limits_.max_duty ? msg.max_duty : limits_.max_duty;
    interlock_duty_ = msg.interlock_duty < limits_.interlock_ceiling ? msg.interlock_duty : limits_.interlock_ceiling;
    uint32_t period = msg.adc_period_us;
    if (period < limits_.adc_period_min_us) period = limits_.adc_period_min_us;
    if (period > limits_.adc_period_max_us) period = limits_.adc_period_max_us;
    adc_period_us_ = period;
    faults_latched_ = 0;
    set_faults(0);
    last_duty_us_ = last_report_us_ = now_us;
  }
  HelloAck ack = {kProtocolVersion, kFwMajor, kFwMinor, kFwPatch, kTickHz, limits_.adc_bits,
                  static_cast<uint16_t>(limits_.watchdog_us / 1000), max_duty_, interlock_duty_, adc_period_us_};
  send(encode(ack, tx_seq_, tx_));
}

void McuCore::on_duty(const Duty& msg, uint8_t seq, uint32_t now_us) {
  duty_seq_ = seq;
  if (configured_) {
    uint16_t faults = faults_ & ~(kFaultInterlock | kFaultRejected);
    if (msg.duty_a > max_duty_ || msg.duty_b > max_duty_) {
      set_faults(faults | kFaultRejected);  // keep the outputs as they are
      send_report(now_us);
      return;
    }
    faults &= ~kFaultWatchdog;
    if (interlock_.apply(msg.duty_a, msg.duty_b, now_us)) faults |= kFaultInterlock;
    pwm_a_ = interlock_.a();
    pwm_b_ = interlock_.b();
    set_faults(faults);
    last_duty_us_ = now_us;
  }
  send_report(now_us);
}

void McuCore::outputs_off(uint32_t now_us) {
  interlock_.reset(now_us);
  pwm_a_ = pwm_b_ = 0;
}

void McuCore::set_faults(uint16_t faults) {
  faults_ = faults;
  faults_latched_ |= faults;
}

void McuCore::send_report(uint32_t now_us) {
  last_report_us_ = now_us;
  AdcReport report = {now_us, read_adc_(ctx_), duty_seq_, faults_, pwm_a_, pwm_b_};
  send(encode(report, tx_seq_, tx_));
}

void McuCore::send_status(uint32_t now_us) {
  last_status_us_ = now_us;
  status_faults_ = faults_;
  Status status = {now_us, faults_, faults_latched_, rx_frames_, rx_crc_errors_, rx_framing_errors_, rx_malformed_};
  send(encode(status, tx_seq_, tx_));
}

void McuCore::send(size_t len) {
  ++tx_seq_;  // uint8_t: wraps at 256 like the Python Sender
  transmit_(tx_, len, ctx_);
}

}  // namespace sma

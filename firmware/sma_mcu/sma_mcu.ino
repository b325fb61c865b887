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

// Reference firmware of the SMA actuator MCU for an Arduino-class board
// (written for an Uno/Nano, ATmega328P at 16 MHz; any Arduino core with analogWrite works).
//
// Wiring: PWM_A (pin 9) and PWM_B (pin 10) drive the two PWM amplifiers (each with its
// current limiter) of wire A and wire B; the shaft potentiometer wiper goes to A0.
// Fit pull-down resistors on both amplifier inputs: during reset and boot the pins float,
// and the wires must stay cold then.
//
// All protocol and safety logic lives in sma_mcu_core.cpp (tested on the host against
// firmware/test_vectors.json); this file only connects it to the pins, the ADC and the
// UART. Protocol: docs/protocol.md. Duty arrives as 16-bit counts; analogWrite is 8-bit
// here, so the top byte is applied (resolution 1/255).
#include <Arduino.h>

#ifdef __AVR__
#include <avr/wdt.h>
#endif

#include "sma_mcu_core.h"

namespace {

const uint8_t kPinPwmA = 9;
const uint8_t kPinPwmB = 10;
const uint8_t kPinPot = A0;
const unsigned long kBaud = 115200;

uint16_t read_pot(void*) { return static_cast<uint16_t>(analogRead(kPinPot)); }

void transmit(const uint8_t* data, size_t len, void*) { Serial.write(data, len); }

sma::FirmwareLimits board_limits() {
  sma::FirmwareLimits limits;
  limits.adc_bits = 10;  // ATmega328P ADC
  return limits;
}

sma::McuCore core(read_pot, transmit, nullptr, board_limits());

void apply_outputs() {
  analogWrite(kPinPwmA, core.pwm_a() >> 8);
  analogWrite(kPinPwmB, core.pwm_b() >> 8);
}

}  // namespace

void setup() {
  pinMode(kPinPwmA, OUTPUT);
  pinMode(kPinPwmB, OUTPUT);
  apply_outputs();  // both off until a Hello and a Duty frame arrive
  Serial.begin(kBaud);
#ifdef __AVR__
  wdt_enable(WDTO_250MS);  // a hung loop resets the MCU, which leaves the outputs off
#endif
  core.start(micros());
}

void loop() {
  while (Serial.available() > 0) core.receive(static_cast<uint8_t>(Serial.read()), micros());
  core.poll(micros());
  apply_outputs();
#ifdef __AVR__
  wdt_reset();
#endif
}

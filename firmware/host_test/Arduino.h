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

// Minimal stand-in for the Arduino core API, so that sma_mcu.ino compiles and runs on the
// host (see sketch_driver.cpp). Only what the sketch uses.
#ifndef SMA_HOST_ARDUINO_H
#define SMA_HOST_ARDUINO_H

#include <stddef.h>
#include <stdint.h>

const uint8_t A0 = 14;
const uint8_t OUTPUT = 1;

unsigned long micros();
void pinMode(uint8_t pin, uint8_t mode);
void analogWrite(uint8_t pin, int value);
int analogRead(uint8_t pin);

class HardwareSerial {
 public:
  void begin(unsigned long baud);
  int available();
  int read();
  size_t write(const uint8_t* data, size_t len);
};
extern HardwareSerial Serial;

#endif  // SMA_HOST_ARDUINO_H

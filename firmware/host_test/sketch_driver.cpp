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

// Runs the real sketch (sma_mcu.ino) on the host against the Arduino.h stand-in.
//
// stdin, one step per line:  "<t_us> [hex bytes]"  -> the bytes arrive on the UART at
// t_us, then loop() runs once. stdout, one line per step:
//   "<t_us> <pwm pin 9> <pwm pin 10> <hex of everything the sketch wrote, or ->"
// The first line is the state right after setup() at t = 0.
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "Arduino.h"

void setup();
void loop();

namespace {
unsigned long now_us = 0;
int pwm[32] = {0};
int adc_value = 2048;
std::vector<uint8_t> rx, tx;
size_t rx_pos = 0;

void print_state() {
  static const char* digits = "0123456789abcdef";
  std::string hex;
  for (uint8_t b : tx) {
    hex += digits[b >> 4];
    hex += digits[b & 15];
  }
  std::cout << now_us << ' ' << pwm[9] << ' ' << pwm[10] << ' ' << (hex.empty() ? "-" : hex) << '\n';
  tx.clear();
}
}  // namespace

HardwareSerial Serial;
unsigned long micros() { return now_us; }
void pinMode(uint8_t, uint8_t) {}
void analogWrite(uint8_t pin, int value) { pwm[pin] = value; }
int analogRead(uint8_t) { return adc_value; }
void HardwareSerial::begin(unsigned long) {}
int HardwareSerial::available() { return static_cast<int>(rx.size() - rx_pos); }
int HardwareSerial::read() { return rx_pos < rx.size() ? rx[rx_pos++] : -1; }
size_t HardwareSerial::write(const uint8_t* data, size_t len) {
  tx.insert(tx.end(), data, data + len);
  return len;
}

int main() {
  setup();
  print_state();
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string hex;
    in >> now_us >> hex;
    for (size_t i = 0; i + 1 < hex.size(); i += 2) rx.push_back(std::stoi(hex.substr(i, 2), nullptr, 16));
    loop();
    print_state();
  }
  return 0;
}

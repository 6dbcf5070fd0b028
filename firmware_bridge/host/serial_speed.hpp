// termios speed constant of a baud rate, shared by the appliance's serial driver and the sensor
// simulator's serial device (both POSIX host code). B0 for a rate the kernel has no constant for.
#pragma once

#include <termios.h>

namespace glint::host {

inline speed_t termios_speed(int baud) {
    switch (baud) {
        case 9600: return B9600;
        case 19200: return B19200;
        case 38400: return B38400;
        case 57600: return B57600;
        case 115200: return B115200;
        case 230400: return B230400;
        case 460800: return B460800;
        case 500000: return B500000;
        case 576000: return B576000;
        case 921600: return B921600;
        case 1000000: return B1000000;
        case 1500000: return B1500000;
        case 2000000: return B2000000;
        case 3000000: return B3000000;
        case 4000000: return B4000000;
        default: return B0;
    }
}

}  // namespace glint::host

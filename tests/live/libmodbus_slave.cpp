// A real Modbus RTU slave for the live tests: libmodbus answering on a serial device until
// the device goes away. Usage: libmodbus_slave DEVICE BAUD PARITY(N|E|O) DATA_BITS STOP_BITS
#include <modbus/modbus.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: %s DEVICE BAUD PARITY DATA_BITS STOP_BITS\n", argv[0]);
    return 2;
  }
  modbus_t* ctx = modbus_new_rtu(argv[1], std::atoi(argv[2]), argv[3][0], std::atoi(argv[4]),
                                 std::atoi(argv[5]));
  modbus_mapping_t* map = modbus_mapping_new(200, 200, 200, 200);
  if (!ctx || !map || modbus_set_slave(ctx, 1) != 0 || modbus_connect(ctx) != 0) {
    std::fprintf(stderr, "libmodbus_slave: %s\n", modbus_strerror(errno));
    return 1;
  }
  for (int i = 0; i < 200; ++i) map->tab_registers[i] = static_cast<uint16_t>(1000 + i);
  uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH];
  for (;;) {
    const int rc = modbus_receive(ctx, query);
    if (rc > 0) {
      modbus_reply(ctx, query, rc, map);
    } else if (rc == -1 && errno != EMBBADCRC && errno != ETIMEDOUT) {
      break;  // the device is gone
    }
  }
  modbus_mapping_free(map);
  modbus_close(ctx);
  modbus_free(ctx);
  return 0;
}

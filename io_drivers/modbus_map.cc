#include "io_drivers/modbus_map.h"

#include <algorithm>
#include <iterator>
#include <vector>

#include "base/yaml_reader.h"

namespace kcrig {

int ModbusMap::holding_count() const {
  int end = std::max({control_word, sequence, session}) + 1;
  for (int a : setpoint) end = std::max(end, a + 2);
  end = std::max(end, z_a + 2);
  return end;
}

int ModbusMap::input_count() const {
  int end = std::max({status, fault_code, sequence_echo, protocol, owner,
                      refused_writes}) +
            1;
  end = std::max(end, sample + 2);
  for (int a : force) end = std::max(end, a + 2);
  for (int a : y) end = std::max(end, a + 2);
  return end;
}

Status LoadModbusMap(const std::string& file, ModbusMap* map) {
  YamlReader reader(file);
  YAML::Node root;
  KCRIG_RETURN_IF_ERROR(reader.Load(&root));
  KCRIG_RETURN_IF_ERROR(
      reader.Integer(root, "", "unit_id", 0, 247, &map->unit_id));
  std::string order_text;
  KCRIG_RETURN_IF_ERROR(reader.String(root, "", "word_order", &order_text));
  if (order_text != "high_word_first" && order_text != "low_word_first") {
    return reader.Error(root["word_order"], "word_order",
                        "must be high_word_first or low_word_first");
  }
  map->high_word_first = order_text == "high_word_first";
  // (key, address, registers) per table; overlaps are errors.
  struct Field {
    const char* key;
    int* address;
    int width;
  };
  const Field holding_fields[] = {{"control_word", &map->control_word, 1},
                                  {"sequence", &map->sequence, 1},
                                  {"fx_setpoint", &map->setpoint[0], 2},
                                  {"fy_setpoint", &map->setpoint[1], 2},
                                  {"fz_setpoint", &map->setpoint[2], 2},
                                  {"za_setpoint", &map->z_a, 2},
                                  {"session", &map->session, 1}};
  const Field input_fields[] = {{"status", &map->status, 1},
                                {"fault_code", &map->fault_code, 1},
                                {"sample", &map->sample, 2},
                                {"sequence_echo", &map->sequence_echo, 1},
                                {"protocol", &map->protocol, 1},
                                {"fx", &map->force[0], 2},
                                {"fy", &map->force[1], 2},
                                {"fz", &map->force[2], 2},
                                {"x", &map->y[0], 2},
                                {"y", &map->y[1], 2},
                                {"z", &map->y[2], 2},
                                {"toe", &map->y[3], 2},
                                {"camber", &map->y[4], 2},
                                {"caster", &map->y[5], 2},
                                {"owner", &map->owner, 1},
                                {"refused_writes", &map->refused_writes, 1}};
  auto load_table = [&](const char* table, const Field* fields,
                        size_t count) -> Status {
    YAML::Node node;
    KCRIG_RETURN_IF_ERROR(reader.Child(root, "", table, &node));
    std::vector<int> owner(256, -1);
    for (size_t i = 0; i < count; ++i) {
      KCRIG_RETURN_IF_ERROR(reader.Integer(node, table, fields[i].key, 0, 254,
                                           fields[i].address));
      for (int r = 0; r < fields[i].width; ++r) {
        int& slot = owner[*fields[i].address + r];
        if (slot >= 0) {
          return reader.Error(node[fields[i].key],
                              std::string(table) + "." + fields[i].key,
                              "overlaps " + std::string(fields[slot].key));
        }
        slot = static_cast<int>(i);
      }
    }
    return Status::Ok();
  };
  KCRIG_RETURN_IF_ERROR(load_table("holding_registers", holding_fields,
                                   std::size(holding_fields)));
  KCRIG_RETURN_IF_ERROR(
      load_table("input_registers", input_fields, std::size(input_fields)));
  if (map->input_count() > 125 || map->holding_count() > 123) {
    return Status::Error(file +
                         ": the map must fit one request per table (<= 125 "
                         "input, <= 123 holding registers)");
  }
  return reader.CheckNoUnknownKeys(root);
}

}  // namespace kcrig

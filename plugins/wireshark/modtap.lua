-- modtap.lua: Wireshark support for the pcapng files `modtap -w` writes (DLT_USER0..15).
--
-- It shows modtap's verdicts (role, check, pairing, latency, findings, noise), and hands each
-- RTU frame to Wireshark's own Modbus RTU dissector with the direction modtap decided, so
-- that the echo codes (05, 06, 08) that mbrtu cannot classify by length are classified too.
-- Modbus ASCII frames, which Wireshark has no dissector for, are decoded here and passed on
-- to the Modbus dissector in RTU form. With a device model (modtap --model, or a device that
-- identified itself), each register's name, scaled value and unit, and the model's findings,
-- come from modtap's one implementation of the models, carried in the packet comment.
--
-- Use: tshark -X lua_script:modtap.lua -o mbrtu.tcp.port:502 -r capture.pcapng
-- (or copy it to ~/.local/lib/wireshark/plugins/ and set the mbrtu TCP port to 502 once).

local modtap = Proto("modtap", "modtap serial Modbus")

-- modtap puts the slave side of every frame on this port, the master side on the other.
local SLAVE_PORT = 502
local MASTER_PORT = 50200

local fields = {
  index = ProtoField.uint32("modtap.index", "Record"),
  mode = ProtoField.string("modtap.mode", "Mode"),
  role = ProtoField.string("modtap.role", "Role"),
  check = ProtoField.string("modtap.check", "Check"),
  expected = ProtoField.string("modtap.expected", "Expected check"),
  request = ProtoField.framenum("modtap.request", "Request in frame", base.NONE, frametype.REQUEST),
  latency = ProtoField.double("modtap.latency_us", "Latency (us)"),
  finding = ProtoField.string("modtap.finding", "Finding"),
  noise = ProtoField.string("modtap.noise", "Noise"),
  slave = ProtoField.uint8("modtap.ascii.slave", "Slave"),
  fc = ProtoField.uint8("modtap.ascii.fc", "Function code", base.DEC),
  data = ProtoField.bytes("modtap.ascii.data", "Data"),
  lrc = ProtoField.uint8("modtap.ascii.lrc", "LRC", base.HEX),
  model = ProtoField.string("modtap.model", "Device model"),
  register = ProtoField.string("modtap.register", "Register"),
  reg_addr = ProtoField.uint16("modtap.register.addr", "Address", base.HEX),
  reg_name = ProtoField.string("modtap.register.name", "Name"),
  reg_value = ProtoField.string("modtap.register.value", "Value"),
  note = ProtoField.string("modtap.note", "Model finding"),
}
local field_list = {}
for _, f in pairs(fields) do table.insert(field_list, f) end
modtap.fields = field_list

local bad_check = ProtoExpert.new("modtap.bad_check", "Bad CRC/LRC", expert.group.CHECKSUM,
                                  expert.severity.ERROR)
local finding_expert = ProtoExpert.new("modtap.finding.expert", "modtap finding",
                                       expert.group.SEQUENCE, expert.severity.WARN)
local noise_expert = ProtoExpert.new("modtap.noise.expert", "Bytes outside any frame",
                                     expert.group.MALFORMED, expert.severity.NOTE)
modtap.experts = {bad_check, finding_expert, noise_expert}

local comment_field = Field.new("frame.comment")
local mbrtu = Dissector.get("mbrtu")

-- "modtap index=3 mode=rtu role=response check=ok request=2 finding=... model=gd20", then a
-- line per register ("register 2502H frequency_command = 60.00 Hz") and per model finding
-- ("note read-only-write: ...") -> table
local function verdicts()
  local v = {findings = {}, registers = {}, notes = {}}
  for _, c in ipairs({comment_field()}) do
    local text = tostring(c.value)
    if text:sub(1, 7) == "modtap " then
      local first = text:match("^[^\n]*")
      for key, value in first:gmatch("([%w_]+)=(%S+)") do
        if key == "finding" then table.insert(v.findings, value) else v[key] = value end
      end
      for line in text:gmatch("\n([^\n]*)") do
        local addr, name, value = line:match("^register (%x+)H (.-) = (.*)$")
        if addr then
          table.insert(v.registers, {addr = tonumber(addr, 16), name = name, value = value})
        elseif line:sub(1, 5) == "note " then
          table.insert(v.notes, line:sub(6))
        end
      end
    end
  end
  return v
end

local function crc16(bytes)
  local crc = 0xFFFF
  for i = 0, bytes:len() - 1 do
    crc = bit32.bxor(crc, bytes:get_index(i))
    for _ = 1, 8 do
      if bit32.band(crc, 1) == 1 then
        crc = bit32.bxor(bit32.rshift(crc, 1), 0xA001)
      else
        crc = bit32.rshift(crc, 1)
      end
    end
  end
  return crc
end

-- ':' hex pairs LRC CR LF -> the binary ADU (slave .. LRC), or nil.
local function ascii_adu(tvb)
  local text = tvb:raw()
  local hex = text:match("^:(%x+)\r\n$")
  if not hex or #hex % 2 ~= 0 or #hex < 6 then return nil end
  return ByteArray.new(hex)
end

local function set_ports(pinfo, role)
  if role == "request" then
    pinfo.src_port, pinfo.dst_port = MASTER_PORT, SLAVE_PORT
  elseif role == "response" then
    pinfo.src_port, pinfo.dst_port = SLAVE_PORT, MASTER_PORT
  end
end

local function add_verdicts(tree, tvb, v)
  if v.index then tree:add(fields.index, tonumber(v.index)) end
  if v.mode then tree:add(fields.mode, v.mode) end
  if v.role then tree:add(fields.role, v.role) end
  if v.check then
    local item = tree:add(fields.check, v.check)
    if v.check == "bad" then item:add_proto_expert_info(bad_check, "Bad check, expected " .. (v.expected or "?")) end
  end
  if v.expected then tree:add(fields.expected, v.expected) end
  if v.request then tree:add(fields.request, tonumber(v.request)) end
  if v.latency_us then tree:add(fields.latency, tonumber(v.latency_us)) end
  for _, finding in ipairs(v.findings) do
    tree:add(fields.finding, finding):add_proto_expert_info(finding_expert, finding)
  end
  if v.noise then
    tree:add(fields.noise, v.noise):add_proto_expert_info(noise_expert, "Noise: " .. v.noise)
  end
  if v.model then tree:add(fields.model, v.model) end
  for _, reg in ipairs(v.registers) do
    local label = string.format("%04XH %s = %s", reg.addr, reg.name, reg.value)
    local item = tree:add(fields.register, label)
    item:add(fields.reg_addr, reg.addr)
    item:add(fields.reg_name, reg.name)  -- "-" for a register the model does not know
    item:add(fields.reg_value, reg.value)
  end
  for _, note in ipairs(v.notes) do
    tree:add(fields.note, note):add_proto_expert_info(finding_expert, note)
  end
end

function modtap.dissector(tvb, pinfo, tree)
  local v = verdicts()
  local subtree = tree:add(modtap, tvb(), "modtap")
  add_verdicts(subtree, tvb, v)

  if v.noise then
    pinfo.cols.protocol = "modtap"
    pinfo.cols.info = "Noise (" .. v.noise .. "), " .. tvb:len() .. " bytes"
    return
  end
  set_ports(pinfo, v.role)

  if v.mode == "ascii" or (not v.mode and tvb:len() > 0 and tvb(0, 1):uint() == 0x3A) then
    local adu = ascii_adu(tvb)
    if not adu then
      pinfo.cols.info = "Modbus ASCII (not hex pairs)"
      return
    end
    local n = adu:len()
    local ascii = subtree:add(tvb(), "Modbus ASCII")
    ascii:add(fields.slave, adu:get_index(0))
    ascii:add(fields.fc, adu:get_index(1))
    if n > 3 then ascii:add(fields.data, adu:subset(2, n - 3)) end
    ascii:add(fields.lrc, adu:get_index(n - 1))
    -- The same ADU in RTU form, so Wireshark's Modbus dissector decodes the PDU.
    local rtu = adu:subset(0, n - 1)
    local crc = crc16(rtu)
    local tail = ByteArray.new()
    tail:set_size(2)
    tail:set_index(0, bit32.band(crc, 0xFF))
    tail:set_index(1, bit32.rshift(crc, 8))
    rtu:append(tail)
    mbrtu:call(rtu:tvb("Modbus ASCII as RTU"), pinfo, tree)
    pinfo.cols.protocol = "Modbus ASCII"
    return
  end
  mbrtu:call(tvb, pinfo, tree)
end

local wtap_encap = DissectorTable.get("wtap_encap")
for i = 0, 15 do
  wtap_encap:add(wtap_encaps["USER" .. i], modtap)
end

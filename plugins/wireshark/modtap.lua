-- modtap.lua: Wireshark support for the pcapng files `modtap -w` writes (DLT_USER0..15).
--
-- It shows modtap's verdicts (role, slave, function, check, pairing, latency, time-outs,
-- findings, noise) and an Info line of its own for every record, and hands each frame's PDU to
-- Wireshark's own Modbus dissector with the direction modtap decided. The PDU goes through
-- Modbus/TCP's dissector behind a header made here: that one tells a query from a response by
-- port 502, which is its default, where Modbus RTU's needs a port preference set by hand; the
-- header's transaction number is the request's record number, so Wireshark pairs what modtap
-- paired. Modbus ASCII frames, which Wireshark has no dissector for, go the same way. With a
-- device model (modtap --model, or a device that identified itself), each register's name,
-- scaled value and unit, and the model's findings, come from modtap's one implementation of the
-- models, carried in the packet comment. The names of function and exception codes are modtap's
-- too: the build writes them into this file (the installed one, or build/plugins/wireshark/).
--
-- Use: tshark -X lua_script:build/plugins/wireshark/modtap.lua -r capture.pcapng (or install
-- it: docs/wireshark.md).

local modtap = Proto("modtap", "modtap serial Modbus")

-- The slave side of every frame is on Modbus/TCP's port, the master side on another.
local SLAVE_PORT = 502
local MASTER_PORT = 50200

local fields = {
  index = ProtoField.uint32("modtap.index", "Record"),
  mode = ProtoField.string("modtap.mode", "Mode"),
  role = ProtoField.string("modtap.role", "Role"),
  check = ProtoField.string("modtap.check", "Check"),
  expected_check = ProtoField.string("modtap.expected_check", "Expected check"),
  request = ProtoField.framenum("modtap.request", "Request in frame", base.NONE, frametype.REQUEST),
  latency = ProtoField.double("modtap.latency_us", "Latency (us)"),
  slave = ProtoField.uint8("modtap.slave", "Slave"),
  fc = ProtoField.uint8("modtap.fc", "Function code", base.DEC),
  func = ProtoField.string("modtap.function", "Function"),
  exception = ProtoField.uint8("modtap.exception", "Exception code", base.DEC),
  exception_name = ProtoField.string("modtap.exception_name", "Exception"),
  timeout = ProtoField.string("modtap.timeout", "Timed out"),
  waited = ProtoField.double("modtap.waited_us", "Waited (us)"),
  finding = ProtoField.string("modtap.finding", "Finding"),
  noise = ProtoField.string("modtap.noise", "Noise"),
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
local timeout_expert = ProtoExpert.new("modtap.timeout.expert", "No response", expert.group.SEQUENCE,
                                       expert.severity.WARN)
local exception_expert = ProtoExpert.new("modtap.exception.expert", "Exception response",
                                         expert.group.RESPONSE_CODE, expert.severity.NOTE)
modtap.experts = {bad_check, finding_expert, noise_expert, timeout_expert, exception_expert}

local comment_field = Field.new("frame.comment")
local mbtcp = Dissector.get("mbtcp")

-- modtap's names of the function and exception codes, from its function-code table.
local FUNCTION_NAMES, EXCEPTION_NAMES = {}, {}  -- filled in by the build (lua_names.cpp)

-- Records are numbered by modtap, packets by Wireshark; they differ where records were left
-- out (-Y, a ring of files). A comment names its record only where it is not the one after the
-- packet before's, so Wireshark's first pass, which goes in order, numbers them here.
local frame_of_record, record_of_frame, last_record = {}, {}, 0
-- The model a frame was read with is named where it changed for the frame's first byte (its
-- address on the wire): the first pass carries it from frame to frame.
local model_of_address, model_of_frame = {}, {}

function modtap.init()  -- a new file, or everything dissected again
  frame_of_record, record_of_frame, last_record = {}, {}, 0
  model_of_address, model_of_frame = {}, {}
end

-- The comment's first line's "key=value" pairs (a value in quotes where it holds spaces) into
-- v; a finding may come more than once.
local function read_keys(line, v)
  local at, size = 8, #line  -- after "modtap "
  while at <= size do
    local eq = line:find("=", at, true)
    if not eq then return end
    local key, value = line:sub(at, eq - 1), nil
    if line:byte(eq + 1) == 34 then  -- '"'
      local close = line:find('"', eq + 2, true) or size + 1
      value, at = line:sub(eq + 2, close - 1), close + 2
    else
      local space = line:find(" ", eq + 1, true) or size + 1
      value, at = line:sub(eq + 1, space - 1), space + 1
    end
    if key == "finding" then
      v.findings = v.findings or {}
      v.findings[#v.findings + 1] = value
    else
      v[key] = value
    end
  end
end

-- "register 2502H frequency_command = 60.00 Hz" and "note read-only-write: ..." lines into v.
local function read_meaning(text, from, v)
  for line in text:sub(from):gmatch("[^\n]+") do
    local addr, name, value = line:match("^register (%x+)H (.-) = (.*)$")
    if addr then
      v.registers = v.registers or {}
      v.registers[#v.registers + 1] = {addr = tonumber(addr, 16), name = name, value = value}
    elseif line:sub(1, 5) == "note " then
      v.notes = v.notes or {}
      v.notes[#v.notes + 1] = line:sub(6)
    end
  end
end

-- The record's verdicts: its comment (docs/pcapng.md), and what a key left out means. Most
-- packets have no findings, registers or notes: they share one empty list.
local ROLE_OF_DIRECTION = {[0] = "request", [1] = "response"}
local NONE = {}
local function verdicts(pinfo)
  local v = {}
  for _, c in ipairs({comment_field()}) do
    local text = tostring(c.value)
    if text:sub(1, 6) == "modtap" then
      local line_end = text:find("\n", 1, true)
      read_keys(line_end and text:sub(1, line_end - 1) or text, v)
      if line_end then read_meaning(text, line_end + 1, v) end
      v.modtap = true
    end
  end
  v.findings, v.registers, v.notes = v.findings or NONE, v.registers or NONE, v.notes or NONE
  if not v.modtap then return v end
  local number = pinfo.number
  if not pinfo.visited then
    local index = tonumber(v.index) or last_record + 1
    last_record, record_of_frame[number], frame_of_record[index] = index, index, number
  end
  v.index = record_of_frame[number]
  v.mode = v.mode or "rtu"
  if not v.noise then
    v.role = v.role or ROLE_OF_DIRECTION[pinfo.p2p_dir] or "unknown"
    v.check = v.check or "ok"
    if v.role == "response" and v.request == nil then v.request = v.index - 1 end
  end
  v.request = v.request and tonumber(v.request)  -- "none": a response nobody asked for
  return v
end

local function carry_model(tvb, pinfo, v)
  local number = pinfo.number
  if not pinfo.visited then
    local address = tvb:len() > 0 and tvb:raw(0, 1) or ""
    if v.model then model_of_address[address] = v.model ~= "none" and v.model or nil end
    model_of_frame[number] = model_of_address[address]
  end
  v.model = model_of_frame[number]
end

local function set_ports(pinfo, role)
  if role == "request" then
    pinfo.src_port, pinfo.dst_port = MASTER_PORT, SLAVE_PORT
  elseif role == "response" then
    pinfo.src_port, pinfo.dst_port = SLAVE_PORT, MASTER_PORT
  end
end

local function add_verdicts(tree, v, pinfo)
  if v.index then tree:add(fields.index, v.index) end
  if v.mode then tree:add(fields.mode, v.mode) end
  if v.role then tree:add(fields.role, v.role) end
  if v.check then
    local item = tree:add(fields.check, v.check)
    if v.check == "bad" then
      local why = v.damage == "cut" and "Bad check: the frame was cut before it"
                  or "Bad check, expected " .. v.expected_check
      item:add_proto_expert_info(bad_check, why)
    end
  end
  if v.expected_check then tree:add(fields.expected_check, v.expected_check) end
  local request = v.request and frame_of_record[v.request]
  if request and request < pinfo.number then tree:add(fields.request, request) end
  if v.latency_us then tree:add(fields.latency, tonumber(v.latency_us)) end
  if v.timeout then
    tree:add(fields.timeout, v.timeout):add_proto_expert_info(timeout_expert,
      string.format("No response (%s) after %.1f ms", v.timeout, (tonumber(v.waited_us) or 0) / 1000))
    if v.waited_us then tree:add(fields.waited, tonumber(v.waited_us)) end
  end
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
    item:add(fields.reg_name, reg.name)  -- "-" in files before 2026-11-24: a register unnamed
    item:add(fields.reg_value, reg.value)
  end
  for _, note in ipairs(v.notes) do
    tree:add(fields.note, note):add_proto_expert_info(finding_expert, note)
  end
end

-- The frame's ADU without its check (an ASCII frame's decoded) as a string of bytes, and
-- whether the frame is ASCII; no ADU where too little of it came. Strings, not ByteArrays:
-- each ByteArray call crosses into C, and these run for every packet.
local function adu_of(tvb, v)
  local size = tvb:len()
  if v.mode == "ascii" then
    local hex = tvb:raw():match("^:(%x+)\r\n$")
    if not hex or #hex % 2 ~= 0 or #hex < 6 then return nil, true end
    local adu = (hex:gsub("%x%x", function(pair) return string.char(tonumber(pair, 16)) end))
    if v.damage == "cut" then return adu, true end  -- ended before its LRC
    return adu:sub(1, -2), true
  end
  if v.damage == "cut" then  -- no check at its end: what there is names slave and function
    if size < 2 then return nil, false end
    return tvb:raw(), false
  end
  if size < 4 then return nil, false end
  return tvb:raw(0, size - 2), false
end

-- Slave, function and its name, and the exception's name: the words of the Info line.
local function identity(adu, v)
  local slave, fc = adu:byte(1), bit32.band(adu:byte(2), 0x7F)
  local name = FUNCTION_NAMES[fc] or string.format("Function 0x%02X", fc)
  if not v.exception then return slave, fc, name, nil end
  local text = v.exception_name or EXCEPTION_NAMES[tonumber(v.exception)]
               or "not a standard exception"
  for _, note in ipairs(v.notes) do  -- a vendor's meaning, from the device model
    local vendor = note:match("^exception: (vendor .*)$")
    if vendor then text = vendor end
  end
  return slave, fc, name, text
end

-- The fields every frame has.
local function add_identity(tree, v, slave, fc, name, exception)
  tree:add(fields.slave, slave)
  tree:add(fields.fc, fc)
  tree:add(fields.func, name)
  if exception then
    tree:add(fields.exception, tonumber(v.exception))
    tree:add(fields.exception_name, exception):add_proto_expert_info(exception_expert,
      "Exception " .. v.exception .. ": " .. exception)
  end
end

local ROLE_WORDS = {request = "Request ", response = "Response", unknown = "Unknown "}

local function info_line(v, slave, fc, name, exception)
  local code = FUNCTION_NAMES[fc] and string.format(" (%d)", fc) or ""
  local words = {string.format("%s slave %-3d %s%s", ROLE_WORDS[v.role] or "Frame   ", slave, name, code)}
  if exception then
    local vendor = exception:match("^vendor ")
    table.insert(words, vendor and exception or string.format("exception %02d: %s", tonumber(v.exception), exception))
  end
  if v.latency_us then table.insert(words, string.format("%.3f ms", tonumber(v.latency_us) / 1000)) end
  if v.check == "bad" then
    local check = "BAD " .. (v.mode == "ascii" and "LRC" or "CRC")
    table.insert(words, v.damage and check .. " (" .. v.damage .. ")" or check)
  end
  if v.timeout then table.insert(words, "NO RESPONSE (" .. v.timeout .. ")") end
  for _, finding in ipairs(v.findings) do
    if finding ~= "bad-check" then table.insert(words, "[" .. finding .. "]") end
  end
  return table.concat(words, "  ")
end

-- The PDU behind a Modbus/TCP header: transaction = the request's record number.
local function as_modbus_tcp(adu, v)
  local pair = (v.role == "response" and v.request or v.index) or 0
  local header = string.char(bit32.band(bit32.rshift(pair, 8), 0xFF), bit32.band(pair, 0xFF), 0, 0,
                             bit32.rshift(#adu, 8), bit32.band(#adu, 0xFF))
  return ByteArray.new(header .. adu, true)
end

-- The ASCII frame's decoded bytes and its LRC.
local function add_ascii(tree, tvb, adu, v)
  local item = tree:add(tvb(), "Modbus ASCII")
  if #adu > 2 then
    item:add(fields.data, ByteArray.new(adu, true):tvb("Modbus ASCII, decoded")(2, #adu - 2))
  end
  if v.damage ~= "cut" then item:add(fields.lrc, tonumber(tvb:raw():sub(-4, -3), 16)) end
end

function modtap.dissector(tvb, pinfo, tree)
  local v = verdicts(pinfo)
  if v.modtap and not v.noise then carry_model(tvb, pinfo, v) end
  local subtree = tree:add(modtap, tvb(), "modtap")
  add_verdicts(subtree, v, pinfo)

  if v.noise then
    pinfo.cols.protocol = "modtap"
    pinfo.cols.info = string.format("Noise (%s), %d byte%s", v.noise, tvb:len(), tvb:len() == 1 and "" or "s")
    return
  end
  local adu, ascii = adu_of(tvb, v)
  if not adu then
    pinfo.cols.protocol = ascii and "Modbus ASCII" or "Modbus RTU"
    pinfo.cols.info = "Frame cut before its function code, " .. tvb:len() .. " byte(s)"
    return
  end
  local slave, fc, name, exception = identity(adu, v)
  if ascii then add_ascii(subtree, tvb, adu, v) end
  add_identity(subtree, v, slave, fc, name, exception)
  if v.damage ~= "cut" then  -- half a PDU would only read as malformed
    set_ports(pinfo, v.role)
    mbtcp:call(as_modbus_tcp(adu, v):tvb("Modbus PDU"), pinfo, tree)
  end
  pinfo.cols.protocol = ascii and "Modbus ASCII" or "Modbus RTU"
  pinfo.cols.info = info_line(v, slave, fc, name, exception)
end

local wtap_encap = DissectorTable.get("wtap_encap")
for i = 0, 15 do
  wtap_encap:add(wtap_encaps["USER" .. i], modtap)
end

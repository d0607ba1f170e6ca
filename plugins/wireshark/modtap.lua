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
-- models, carried in the packet comment; so do the names of function and exception codes.
--
-- Use: tshark -X lua_script:modtap.lua -r capture.pcapng (or install it: docs/wireshark.md).

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

-- Records are numbered by modtap, packets by Wireshark; they differ where records were left
-- out (-Y, a ring of files). Wireshark's first pass goes in order, which fills this in.
local frame_of_record = {}

function modtap.init()  -- a new file, or everything dissected again
  frame_of_record = {}
end

-- "modtap index=3 mode=rtu role=response check=ok request=2 finding=... model=gd20", then a
-- line per register ("register 2502H frequency_command = 60.00 Hz") and per model finding
-- ("note read-only-write: ...") -> table
local function verdicts()
  local v = {findings = {}, registers = {}, notes = {}}
  for _, c in ipairs({comment_field()}) do
    local text = tostring(c.value)
    if text:sub(1, 7) == "modtap " then
      local first = text:match("^[^\n]*")
      for key, value in first:gmatch('([%w_]+)="([^"]*)"') do v[key] = value end
      for key, value in first:gmatch('([%w_]+)=([^"%s]%S*)') do
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
  v.expected_check = v.expected_check or v.expected  -- the key's name in older files
  return v
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

local function add_verdicts(tree, v, pinfo)
  if v.index then tree:add(fields.index, tonumber(v.index)) end
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
  local request = v.request and frame_of_record[tonumber(v.request)]
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

-- The frame's ADU without its check (binary, also for ASCII) and the source's bytes, or nil.
local function adu_of(tvb, v)
  if v.mode == "ascii" or (not v.mode and tvb:len() > 0 and tvb(0, 1):uint() == 0x3A) then
    local adu = ascii_adu(tvb)
    if not adu then return nil end
    if v.damage == "cut" then return adu, true end  -- ended before its LRC
    return adu:subset(0, adu:len() - 1), true
  end
  if v.damage == "cut" then  -- no check at its end: what there is names slave and function
    if tvb:len() < 2 then return nil end
    return tvb:bytes(), false
  end
  if tvb:len() < 4 then return nil end
  return tvb:bytes():subset(0, tvb:len() - 2), false
end

-- Slave, function, exception: the fields every frame has, and the words of the Info line.
local function add_identity(tree, adu, v)
  local slave, fc = adu:get_index(0), adu:get_index(1)
  tree:add(fields.slave, slave)
  tree:add(fields.fc, bit32.band(fc, 0x7F))
  local name = v["function"] or string.format("Function 0x%02X", bit32.band(fc, 0x7F))
  tree:add(fields.func, name)
  if v.exception then
    local text = v.exception_name or "not a standard exception"
    for _, note in ipairs(v.notes) do  -- a vendor's meaning, from the device model
      local vendor = note:match("^exception: (vendor .*)$")
      if vendor then text = vendor end
    end
    tree:add(fields.exception, tonumber(v.exception))
    tree:add(fields.exception_name, text):add_proto_expert_info(exception_expert,
      "Exception " .. v.exception .. ": " .. text)
    return slave, fc, name, text
  end
  return slave, fc, name, nil
end

local ROLE_WORDS = {request = "Request ", response = "Response", unknown = "Unknown "}

local function info_line(v, slave, fc, name, exception)
  local code = v["function"] and string.format(" (%d)", bit32.band(fc, 0x7F)) or ""
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
  local pair = tonumber(v.role == "response" and v.request or v.index) or 0
  local length = adu:len()  -- unit and PDU
  local header = ByteArray.new()
  header:set_size(6)
  header:set_index(0, bit32.band(bit32.rshift(pair, 8), 0xFF))
  header:set_index(1, bit32.band(pair, 0xFF))
  header:set_index(4, bit32.band(bit32.rshift(length, 8), 0xFF))
  header:set_index(5, bit32.band(length, 0xFF))
  header:append(adu)
  return header
end

function modtap.dissector(tvb, pinfo, tree)
  local v = verdicts()
  if v.index and not pinfo.visited then frame_of_record[tonumber(v.index)] = pinfo.number end
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
  if ascii then
    local n = adu:len()
    local item = subtree:add(tvb(), "Modbus ASCII")
    if n > 2 then item:add(fields.data, adu:tvb("Modbus ASCII, decoded")(2, n - 2)) end
    if v.damage ~= "cut" then item:add(fields.lrc, tonumber(tvb:raw():sub(-4, -3), 16)) end
  end
  local slave, fc, name, exception = add_identity(subtree, adu, v)
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

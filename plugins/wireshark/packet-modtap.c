/* packet-modtap.c: Wireshark's dissector for the pcapng files `modtap -w` writes (DLT_USER0..15).
 *
 * It shows modtap's verdicts (role, slave, function, check, pairing, latency, time-outs,
 * findings, noise, a device model's registers and findings) and an Info line of modtap's for
 * every record, read from the packet's comment (docs/pcapng.md), and hands each frame's PDU to
 * Wireshark's own Modbus dissector as the query or response modtap decided, with the request's
 * record number as its transaction, so that Wireshark pairs what modtap paired. Modbus ASCII
 * frames, which Wireshark has no dissector for, go the same way once their hex is decoded.
 *
 * Names of codes and titles of fields come from modtap's own tables (modtap_names.h, written by
 * the build). A C plugin, not Lua: docs/wireshark.md says why.
 */
#include <stdlib.h>
#include <string.h>

#include <epan/expert.h>
#include <epan/packet.h>
#include <epan/proto_data.h>
#include <wiretap/wtap.h>
#include <ws_version.h>

#include <epan/dissectors/packet-mbtcp.h> /* after epan/packet.h, whose types it uses */

#include "modtap_names.h"

WS_DLL_PUBLIC_DEF const gchar plugin_version[] = MODTAP_VERSION;
WS_DLL_PUBLIC_DEF const int plugin_want_major = WIRESHARK_VERSION_MAJOR;
WS_DLL_PUBLIC_DEF const int plugin_want_minor = WIRESHARK_VERSION_MINOR;
WS_DLL_PUBLIC void plugin_register(void);

static int proto_modtap = -1;
static dissector_handle_t modbus_handle;

static int hf_index = -1, hf_mode = -1, hf_role = -1, hf_check = -1, hf_expected_check = -1;
static int hf_request = -1, hf_latency = -1, hf_slave = -1, hf_fc = -1, hf_function = -1;
static int hf_exception = -1, hf_exception_name = -1, hf_timeout = -1, hf_waited = -1;
static int hf_no_response = -1;
static int hf_finding = -1, hf_noise = -1, hf_data = -1, hf_lrc = -1, hf_model = -1;
static int hf_register = -1, hf_register_addr = -1, hf_register_name = -1;
static int hf_register_value = -1, hf_note = -1;
static gint ett_modtap = -1, ett_register = -1, ett_ascii = -1;
static expert_field ei_bad_check = EI_INIT, ei_finding = EI_INIT, ei_noise = EI_INIT;
static expert_field ei_timeout = EI_INIT, ei_exception = EI_INIT;

/* What a packet's comment says, with the defaults a key left out means (docs/pcapng.md). */
#define MAX_FINDINGS 16
typedef struct {
  gboolean modtap;   /* the comment is modtap's */
  const char* index; /* the record number, where not the one after the packet before's */
  const char *mode, *role, *check, *damage, *noise, *timeout, *model, *exception_name;
  const char *expected_check, *request, *latency_us, *waited_us, *exception;
  const char* findings[MAX_FINDINGS];
  int finding_count;
  char* meaning; /* the lines after the first: registers and the model's findings */
} verdicts_t;

/* What the first pass, which goes in order, learns of a packet for every later one. */
typedef struct {
  guint64 record;
  guint64 request;       /* a response's request, by record number (0: none) */
  guint32 request_frame; /* its packet (0: none, or not in this file) */
  const char* model;     /* NULL: read with none */
} packet_state_t;

/* Per file: the record the last packet held, each record's packet, and per first byte of a
 * frame (its address on the wire) the model its last frame was read with. */
static guint64 last_record;
static wmem_map_t* frame_of_record;
static wmem_map_t* model_names;
static const char* model_of_address[256];

static void modtap_init(void) {
  last_record = 0;
  memset(model_of_address, 0, sizeof model_of_address);
}

/* Sets the verdict named `key` to `value`, both in the packet's copy of the comment. */
static void set_key(verdicts_t* v, const char* key, const char* value) {
  static const struct {
    const char* key;
    size_t offset;
  } keys[] = {
      {"index", offsetof(verdicts_t, index)},
      {"mode", offsetof(verdicts_t, mode)},
      {"role", offsetof(verdicts_t, role)},
      {"check", offsetof(verdicts_t, check)},
      {"damage", offsetof(verdicts_t, damage)},
      {"noise", offsetof(verdicts_t, noise)},
      {"timeout", offsetof(verdicts_t, timeout)},
      {"model", offsetof(verdicts_t, model)},
      {"exception_name", offsetof(verdicts_t, exception_name)},
      {"expected_check", offsetof(verdicts_t, expected_check)},
      {"request", offsetof(verdicts_t, request)},
      {"latency_us", offsetof(verdicts_t, latency_us)},
      {"waited_us", offsetof(verdicts_t, waited_us)},
      {"exception", offsetof(verdicts_t, exception)},
  };
  if (strcmp(key, "finding") == 0) {
    if (v->finding_count < MAX_FINDINGS) v->findings[v->finding_count++] = value;
    return;
  }
  for (size_t i = 0; i < G_N_ELEMENTS(keys); ++i)
    if (strcmp(key, keys[i].key) == 0) {
      *(const char**)((char*)v + keys[i].offset) = value;
      return;
    }
}

/* The first line's "key=value" pairs, a value in quotes where it holds spaces. */
static void read_keys(char* line, verdicts_t* v) {
  char* at = line;
  while (*at) {
    char* key = at;
    char* eq = strchr(key, '=');
    if (!eq) return;
    *eq = '\0';
    char* value = eq + 1;
    char* end;
    if (*value == '"') {
      ++value;
      end = strchr(value, '"');
    } else {
      end = strchr(value, ' ');
    }
    at = end ? end + 1 : value + strlen(value);
    if (end) *end = '\0';
    if (*at == ' ') ++at;
    set_key(v, key, value);
  }
}

static verdicts_t read_comment(packet_info* pinfo) {
  verdicts_t v;
  memset(&v, 0, sizeof v);
  char* comment = NULL;
  if (!pinfo->rec || !pinfo->rec->block ||
      wtap_block_get_nth_string_option_value(pinfo->rec->block, OPT_COMMENT, 0, &comment) !=
          WTAP_OPTTYPE_SUCCESS ||
      strncmp(comment, "modtap", 6) != 0 ||
      (comment[6] != ' ' && comment[6] != '\0' && comment[6] != '\n'))
    return v;
  char* text = wmem_strdup(pinfo->pool, comment);
  char* newline = strchr(text, '\n');
  if (newline) {
    *newline = '\0';
    v.meaning = newline + 1;
  }
  v.modtap = TRUE;
  read_keys(text + 6 + (text[6] == ' '), &v);
  return v;
}

static const char* interned_model(const char* name) {
  const char* kept = (const char*)wmem_map_lookup(model_names, name);
  if (!kept) {
    kept = wmem_strdup(wmem_file_scope(), name);
    wmem_map_insert(model_names, kept, (void*)kept);
  }
  return kept;
}

static const char* role_of(const verdicts_t* v, packet_info* pinfo) {
  if (v->role) return v->role;
  if (pinfo->p2p_dir == P2P_DIR_SENT) return "request";
  if (pinfo->p2p_dir == P2P_DIR_RECV) return "response";
  return "unknown";
}

/* What the first pass learns: the record number, the request's packet, the model. Only a
 * request's packet is kept by its record number: only a request is looked up so. */
static packet_state_t* packet_state(tvbuff_t* tvb, packet_info* pinfo, const verdicts_t* v) {
  packet_state_t* state =
      (packet_state_t*)p_get_proto_data(wmem_file_scope(), pinfo, proto_modtap, 0);
  if (state) return state;
  state = wmem_new0(wmem_file_scope(), packet_state_t);
  state->record = v->index ? g_ascii_strtoull(v->index, NULL, 10) : last_record + 1;
  last_record = state->record;
  const char* role = v->noise ? "noise" : role_of(v, pinfo);
  if (strcmp(role, "request") == 0)
    wmem_map_insert(frame_of_record, GSIZE_TO_POINTER(state->record), GUINT_TO_POINTER(pinfo->num));
  if (v->request)
    state->request = g_ascii_strtoull(v->request, NULL, 10); /* "none": 0 */
  else if (strcmp(role, "response") == 0)
    state->request = state->record - 1;
  if (state->request)
    state->request_frame =
        GPOINTER_TO_UINT(wmem_map_lookup(frame_of_record, GSIZE_TO_POINTER(state->request)));
  if (!v->noise && tvb_captured_length(tvb) > 0) {
    const char** model = &model_of_address[tvb_get_guint8(tvb, 0)];
    if (v->model) *model = strcmp(v->model, "none") == 0 ? NULL : interned_model(v->model);
    state->model = *model;
  }
  p_add_proto_data(wmem_file_scope(), pinfo, proto_modtap, 0, state);
  return state;
}

/* "register 2502H frequency_command = 60.00 Hz" and "note KIND: TEXT" lines. */
static void add_meaning(proto_tree* tree, packet_info* pinfo, tvbuff_t* tvb, const char* lines) {
  if (!lines) return;
  for (char* line = wmem_strdup(pinfo->pool, lines); *line;) {
    char* next = strchr(line, '\n');
    if (next) *next++ = '\0';
    unsigned addr;
    int name_at = 0;
    if (sscanf(line, "register %xH %n", &addr, &name_at) == 1 && name_at > 0) {
      char* name = line + name_at;
      char* value = strstr(name, " = ");
      if (value) {
        *value = '\0';
        value += 3;
        proto_item* item = proto_tree_add_string_format_value(tree, hf_register, tvb, 0, 0, "",
                                                              "%04XH %s = %s", addr, name, value);
        proto_tree* sub = proto_item_add_subtree(item, ett_register);
        proto_tree_add_uint(sub, hf_register_addr, tvb, 0, 0, addr);
        proto_tree_add_string(sub, hf_register_name, tvb, 0, 0, name);
        proto_tree_add_string(sub, hf_register_value, tvb, 0, 0, value);
      }
    } else if (strncmp(line, "note ", 5) == 0) {
      proto_item* item = proto_tree_add_string(tree, hf_note, tvb, 0, 0, line + 5);
      expert_add_info_format(pinfo, item, &ei_finding, "%s", line + 5);
    }
    if (!next) break;
    line = next;
  }
}

static void add_verdicts(proto_tree* tree, packet_info* pinfo, tvbuff_t* tvb, const verdicts_t* v,
                         const packet_state_t* state, const char* role) {
  proto_tree_add_uint64(tree, hf_index, tvb, 0, 0, state->record);
  proto_tree_add_string(tree, hf_mode, tvb, 0, 0, v->mode ? v->mode : "rtu");
  if (!v->noise) {
    proto_tree_add_string(tree, hf_role, tvb, 0, 0, role);
    proto_item* check =
        proto_tree_add_string(tree, hf_check, tvb, 0, 0, v->check ? v->check : "ok");
    if (v->check && strcmp(v->check, "bad") == 0) {
      if (v->damage && strcmp(v->damage, "cut") == 0)
        expert_add_info_format(pinfo, check, &ei_bad_check,
                               "Bad check: the frame was cut before it");
      else
        expert_add_info_format(pinfo, check, &ei_bad_check, "Bad check, expected %s",
                               v->expected_check ? v->expected_check : "?");
    }
  }
  if (v->expected_check)
    proto_tree_add_uint(tree, hf_expected_check, tvb, 0, 0,
                        (guint32)g_ascii_strtoull(v->expected_check, NULL, 16));
  if (state->request_frame && state->request_frame < pinfo->num)
    proto_tree_add_uint(tree, hf_request, tvb, 0, 0, state->request_frame);
  if (v->latency_us)
    proto_tree_add_double(tree, hf_latency, tvb, 0, 0, g_ascii_strtod(v->latency_us, NULL));
  if (v->timeout) {
    double waited = v->waited_us ? g_ascii_strtod(v->waited_us, NULL) : 0;
    proto_item* item = proto_tree_add_string(tree, hf_timeout, tvb, 0, 0, v->timeout);
    expert_add_info_format(pinfo, item, &ei_timeout, "No response (%s) after %.1f ms", v->timeout,
                           waited / 1000);
    if (v->waited_us) proto_tree_add_double(tree, hf_waited, tvb, 0, 0, waited);
    /* What the Findings column shows a person: the time-out and the time waited. */
    proto_tree_add_string(tree, hf_no_response, tvb, 0, 0,
                          v->waited_us
                              ? wmem_strdup_printf(pinfo->pool, "timeout %.1f ms", waited / 1000)
                              : "timeout");
  }
  for (int i = 0; i < v->finding_count; ++i) {
    proto_item* item = proto_tree_add_string(tree, hf_finding, tvb, 0, 0, v->findings[i]);
    expert_add_info_format(pinfo, item, &ei_finding, "%s", v->findings[i]);
  }
  if (v->noise) {
    proto_item* item = proto_tree_add_string(tree, hf_noise, tvb, 0, 0, v->noise);
    expert_add_info_format(pinfo, item, &ei_noise, "Noise: %s", v->noise);
  }
  if (state->model) proto_tree_add_string(tree, hf_model, tvb, 0, 0, state->model);
  add_meaning(tree, pinfo, tvb, v->meaning);
}

/* An ASCII frame's ':' hex pairs LRC CR LF, decoded into a tvb of its own; NULL if malformed. */
static tvbuff_t* decoded_ascii(tvbuff_t* tvb, packet_info* pinfo) {
  const gint size = tvb_captured_length(tvb);
  if (size < 9 || (size - 3) % 2 != 0 || tvb_get_guint8(tvb, 0) != ':' ||
      tvb_get_guint8(tvb, size - 2) != '\r' || tvb_get_guint8(tvb, size - 1) != '\n')
    return NULL;
  const guint8* hex = tvb_get_ptr(tvb, 1, size - 3);
  const gint bytes = (size - 3) / 2;
  guint8* adu = (guint8*)wmem_alloc(pinfo->pool, bytes);
  for (gint i = 0; i < bytes; ++i) {
    const int high = g_ascii_xdigit_value(hex[2 * i]), low = g_ascii_xdigit_value(hex[2 * i + 1]);
    if (high < 0 || low < 0) return NULL;
    adu[i] = (guint8)(high << 4 | low);
  }
  tvbuff_t* decoded = tvb_new_child_real_data(tvb, adu, bytes, bytes);
  add_new_data_source(pinfo, decoded, "Modbus ASCII, decoded");
  return decoded;
}

static void add_ascii(proto_tree* tree, tvbuff_t* tvb, tvbuff_t* adu, gboolean cut) {
  proto_tree* ascii = proto_tree_add_subtree(tree, tvb, 0, -1, ett_ascii, NULL, "Modbus ASCII");
  const gint size = tvb_captured_length(adu);
  if (size > 2) proto_tree_add_item(ascii, hf_data, adu, 2, size - 2 - (cut ? 0 : 1), ENC_NA);
  if (!cut) proto_tree_add_item(ascii, hf_lrc, adu, size - 1, 1, ENC_NA);
}

static const char* function_name(guint8 fc) {
  return modtap_function_names[fc & 0x7F];
}

/* The exception's name: the model's vendor meaning, the comment's, or the standard's. */
static const char* exception_text(packet_info* pinfo, const verdicts_t* v, guint8 code) {
  static const char vendor[] = "note exception: vendor ";
  const char* note = v->meaning ? strstr(v->meaning, vendor) : NULL;
  if (note) {
    const char* text = note + strlen("note exception: ");
    const char* end = strchr(text, '\n');
    return wmem_strndup(pinfo->pool, text, end ? (size_t)(end - text) : strlen(text));
  }
  if (v->exception_name) return v->exception_name;
  return modtap_exception_names[code] ? modtap_exception_names[code] : "not a standard exception";
}

static void set_info(packet_info* pinfo, const verdicts_t* v, const char* role, guint8 slave,
                     guint8 fc, const char* exception, gboolean ascii) {
  static const char* const role_words[] = {"Request ", "Response", "Unknown "};
  const char* word = strcmp(role, "request") == 0    ? role_words[0]
                     : strcmp(role, "response") == 0 ? role_words[1]
                                                     : role_words[2];
  const char* name = function_name(fc);
  if (name)
    col_add_fstr(pinfo->cinfo, COL_INFO, "%s slave %-3u %s (%u)", word, slave, name, fc & 0x7F);
  else
    col_add_fstr(pinfo->cinfo, COL_INFO, "%s slave %-3u Function 0x%02X", word, slave, fc & 0x7F);
  if (exception) {
    if (strncmp(exception, "vendor ", 7) == 0)
      col_append_fstr(pinfo->cinfo, COL_INFO, "  %s", exception);
    else
      col_append_fstr(pinfo->cinfo, COL_INFO, "  exception %02u: %s",
                      (unsigned)strtoul(v->exception, NULL, 10), exception);
  }
  if (v->latency_us)
    col_append_fstr(pinfo->cinfo, COL_INFO, "  %.3f ms",
                    g_ascii_strtod(v->latency_us, NULL) / 1000);
  if (v->check && strcmp(v->check, "bad") == 0) {
    const char* check = ascii ? "BAD LRC" : "BAD CRC";
    if (v->damage)
      col_append_fstr(pinfo->cinfo, COL_INFO, "  %s (%s)", check, v->damage);
    else
      col_append_fstr(pinfo->cinfo, COL_INFO, "  %s", check);
  }
  if (v->timeout) col_append_fstr(pinfo->cinfo, COL_INFO, "  NO RESPONSE (%s)", v->timeout);
  for (int i = 0; i < v->finding_count; ++i)
    if (strcmp(v->findings[i], "bad-check") != 0)
      col_append_fstr(pinfo->cinfo, COL_INFO, "  [%s]", v->findings[i]);
  /* The model's findings by kind ("note device-fault: ..."), but the exception's meaning,
   * which the line says already. */
  for (const char* line = v->meaning; line && *line;) {
    const char* colon = strchr(line, ':');
    const char* end = strchr(line, '\n');
    if (strncmp(line, "note ", 5) == 0 && colon && (!end || colon < end) &&
        strncmp(line, "note exception:", 15) != 0)
      col_append_fstr(pinfo->cinfo, COL_INFO, "  [%.*s]", (int)(colon - line - 5), line + 5);
    line = end ? end + 1 : NULL;
  }
}

/* The frame's PDU to Wireshark's Modbus dissector, as modtap decided its role. */
static void call_modbus(tvbuff_t* adu, packet_info* pinfo, proto_tree* tree, const char* role,
                        const packet_state_t* state, gint pdu_size) {
  modbus_data_t data;
  const gboolean response = strcmp(role, "response") == 0;
  data.packet_type = response                       ? RESPONSE_PACKET
                     : strcmp(role, "request") == 0 ? QUERY_PACKET
                                                    : CANNOT_CLASSIFY;
  /* The transaction pairs a response with its request: the request's record number. */
  data.mbtcp_transid = (guint16)(response ? state->request : state->record);
  data.unit_id = tvb_get_guint8(adu, 0);
  call_dissector_with_data(modbus_handle, tvb_new_subset_length(adu, 1, pdu_size), pinfo, tree,
                           &data);
}

static int dissect_modtap(tvbuff_t* tvb, packet_info* pinfo, proto_tree* tree, void* data _U_) {
  verdicts_t v = read_comment(pinfo);
  if (!v.modtap) return 0;
  const packet_state_t* state = packet_state(tvb, pinfo, &v);
  const char* role = role_of(&v, pinfo);
  proto_item* root = proto_tree_add_item(tree, proto_modtap, tvb, 0, -1, ENC_NA);
  proto_tree* modtap = proto_item_add_subtree(root, ett_modtap);
  add_verdicts(modtap, pinfo, tvb, &v, state, role);

  const gint size = tvb_captured_length(tvb);
  if (v.noise) {
    col_set_str(pinfo->cinfo, COL_PROTOCOL, "modtap");
    col_add_fstr(pinfo->cinfo, COL_INFO, "Noise (%s), %d byte%s", v.noise, size,
                 size == 1 ? "" : "s");
    return size;
  }
  const gboolean ascii = v.mode && strcmp(v.mode, "ascii") == 0;
  const gboolean cut = v.damage && strcmp(v.damage, "cut") == 0;
  col_set_str(pinfo->cinfo, COL_PROTOCOL, ascii ? "Modbus ASCII" : "Modbus RTU");
  tvbuff_t* adu = ascii ? decoded_ascii(tvb, pinfo) : tvb;
  /* The ADU without its check: a cut frame has none. */
  const gint adu_size = adu ? (gint)tvb_captured_length(adu) - (cut ? 0 : ascii ? 1 : 2) : 0;
  if (adu_size < 2) {
    col_add_fstr(pinfo->cinfo, COL_INFO, "Frame cut before its function code, %d byte(s)", size);
    return size;
  }
  if (ascii) add_ascii(modtap, tvb, adu, cut);
  const guint8 slave = tvb_get_guint8(adu, 0), fc = tvb_get_guint8(adu, 1);
  proto_tree_add_uint(modtap, hf_slave, adu, 0, 1, slave);
  proto_tree_add_uint(modtap, hf_fc, adu, 1, 1, fc & 0x7F);
  const char* name = function_name(fc);
  proto_tree_add_string(
      modtap, hf_function, adu, 1, 1,
      name ? name : wmem_strdup_printf(pinfo->pool, "Function 0x%02X", fc & 0x7F));
  const char* exception = NULL;
  if (v.exception) {
    const guint8 code = (guint8)strtoul(v.exception, NULL, 10);
    exception = exception_text(pinfo, &v, code);
    proto_tree_add_uint(modtap, hf_exception, adu, 2, 1, code);
    proto_item* item = proto_tree_add_string(modtap, hf_exception_name, adu, 2, 1, exception);
    expert_add_info_format(pinfo, item, &ei_exception, "Exception %u: %s", code, exception);
  }
  if (!cut) /* half a PDU would only read as malformed */
    call_modbus(adu, pinfo, tree, role, state, adu_size - 1);
  col_set_str(pinfo->cinfo, COL_PROTOCOL, ascii ? "Modbus ASCII" : "Modbus RTU");
  set_info(pinfo, &v, role, slave, fc, exception, ascii);
  return size;
}

/* The field registry's title of a record field (modtap_names.h). */
static const char* title(const char* name) {
  for (size_t i = 0; i < G_N_ELEMENTS(modtap_field_titles); ++i)
    if (strcmp(modtap_field_titles[i].name, name) == 0) return modtap_field_titles[i].title;
  return name;
}

#define FIELD(hf, name, own_title, type, display, strings)              \
  {                                                                     \
    &hf, {                                                              \
      own_title, "modtap." name, type, display, strings, 0, NULL, HFILL \
    }                                                                   \
  }

static void proto_register_modtap(void) {
  /* Titles from the field registry, but for what only a packet says (a time-out, noise,
   * ASCII's own framing), a list's item (a finding, a register, a model's finding) and
   * Wireshark's own frame number. */
  static hf_register_info hf[] = {
      FIELD(hf_index, "index", NULL, FT_UINT64, BASE_DEC, NULL),
      FIELD(hf_mode, "mode", NULL, FT_STRING, BASE_NONE, NULL),
      FIELD(hf_role, "role", NULL, FT_STRING, BASE_NONE, NULL),
      FIELD(hf_check, "check", NULL, FT_STRING, BASE_NONE, NULL),
      FIELD(hf_expected_check, "expected_check", NULL, FT_UINT16, BASE_HEX, NULL),
      FIELD(hf_request, "request", "Request in frame", FT_FRAMENUM, BASE_NONE,
            FRAMENUM_TYPE(FT_FRAMENUM_REQUEST)),
      FIELD(hf_latency, "latency_us", NULL, FT_DOUBLE, BASE_NONE, NULL),
      FIELD(hf_slave, "slave", NULL, FT_UINT8, BASE_DEC, NULL),
      FIELD(hf_fc, "fc", NULL, FT_UINT8, BASE_DEC, NULL),
      FIELD(hf_function, "function", NULL, FT_STRING, BASE_NONE, NULL),
      FIELD(hf_exception, "exception", NULL, FT_UINT8, BASE_DEC, NULL),
      FIELD(hf_exception_name, "exception_name", "Exception", FT_STRING, BASE_NONE, NULL),
      FIELD(hf_timeout, "timeout", "Timed out", FT_STRING, BASE_NONE, NULL),
      FIELD(hf_waited, "waited_us", NULL, FT_DOUBLE, BASE_NONE, NULL),
      FIELD(hf_no_response, "no_response", "No response", FT_STRING, BASE_NONE, NULL),
      FIELD(hf_finding, "finding", "Finding", FT_STRING, BASE_NONE, NULL),
      FIELD(hf_noise, "noise", "Noise", FT_STRING, BASE_NONE, NULL),
      FIELD(hf_data, "ascii.data", "Data", FT_BYTES, BASE_NONE, NULL),
      FIELD(hf_lrc, "ascii.lrc", "LRC", FT_UINT8, BASE_HEX, NULL),
      FIELD(hf_model, "model", NULL, FT_STRING, BASE_NONE, NULL),
      FIELD(hf_register, "register", "Register", FT_STRING, BASE_NONE, NULL),
      FIELD(hf_register_addr, "register.addr", "Address", FT_UINT16, BASE_HEX, NULL),
      FIELD(hf_register_name, "register.name", "Name", FT_STRING, BASE_NONE, NULL),
      FIELD(hf_register_value, "register.value", "Value", FT_STRING, BASE_NONE, NULL),
      FIELD(hf_note, "note", "Model finding", FT_STRING, BASE_NONE, NULL),
  };
  static gint* ett[] = {&ett_modtap, &ett_register, &ett_ascii};
  static ei_register_info ei[] = {
      {&ei_bad_check, {"modtap.expert.bad_check", PI_CHECKSUM, PI_ERROR, "Bad CRC/LRC", EXPFILL}},
      {&ei_finding, {"modtap.expert.finding", PI_SEQUENCE, PI_WARN, "modtap finding", EXPFILL}},
      {&ei_noise,
       {"modtap.expert.noise", PI_MALFORMED, PI_NOTE, "Bytes outside any frame", EXPFILL}},
      {&ei_timeout, {"modtap.expert.timeout", PI_SEQUENCE, PI_WARN, "No response", EXPFILL}},
      {&ei_exception,
       {"modtap.expert.exception", PI_RESPONSE_CODE, PI_NOTE, "Exception response", EXPFILL}},
  };
  for (size_t i = 0; i < G_N_ELEMENTS(hf); ++i)
    if (!hf[i].hfinfo.name) hf[i].hfinfo.name = title(hf[i].hfinfo.abbrev + strlen("modtap."));
  proto_modtap = proto_register_protocol("modtap serial Modbus", "modtap", "modtap");
  proto_register_field_array(proto_modtap, hf, G_N_ELEMENTS(hf));
  proto_register_subtree_array(ett, G_N_ELEMENTS(ett));
  expert_register_field_array(expert_register_protocol(proto_modtap), ei, G_N_ELEMENTS(ei));
  frame_of_record =
      wmem_map_new_autoreset(wmem_epan_scope(), wmem_file_scope(), g_direct_hash, g_direct_equal);
  model_names =
      wmem_map_new_autoreset(wmem_epan_scope(), wmem_file_scope(), g_str_hash, g_str_equal);
  register_init_routine(modtap_init);
}

static void proto_reg_handoff_modtap(void) {
  dissector_handle_t handle = create_dissector_handle(dissect_modtap, proto_modtap);
  for (int encap = WTAP_ENCAP_USER0; encap <= WTAP_ENCAP_USER15; ++encap)
    dissector_add_uint("wtap_encap", encap, handle);
  modbus_handle = find_dissector_add_dependency("modbus", proto_modtap);
}

void plugin_register(void) {
  static proto_plugin plugin;
  plugin.register_protoinfo = proto_register_modtap;
  plugin.register_handoff = proto_reg_handoff_modtap;
  proto_register_plugin(&plugin);
}

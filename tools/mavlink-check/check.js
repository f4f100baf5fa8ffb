// Independent MAVLink v2 decoder/encoder for Ridgeline's tests (tests/mavlink/
// node_mavlink_crosscheck_test.cpp), built on the npm packages node-mavlink and
// mavlink-mappings, which share no code with Ridgeline's src/mavlink.
//
//   node check.js IN.json OUT.json
//
// IN.json:  { "decode": ["<frame hex>", ...],
//             "encode": [{"msgid": 84, "seq": 1, "sysid": 1, "compid": 1,
//                         "fields": {"<common.xml field name>": value, ...}}, ...] }
// OUT.json: { "versions": {...},
//             "decoded": [{"msgid", "seq", "sysid", "compid", "incompat_flags",
//                          "payload_length", "crc", "fields": {...}}, ...],
//             "invalid": <frames node-mavlink's splitter dropped (bad CRC or unknown)>,
//             "encoded": ["<frame hex>", ...] }
// Decoding goes through MavLinkPacketSplitter, which checks each frame's checksum with the
// message's CRC_EXTRA ("magic number"); frames it drops are missing from "decoded".
'use strict';
const fs = require('fs');
const path = require('path');
const { MavLinkPacketSplitter, MavLinkPacketParser, MavLinkProtocolV2, minimal, common } =
    require('node-mavlink');

const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY };

function fieldsOf(data, clazz) {
  const out = {};
  for (const f of clazz.FIELDS) out[f.source] = data[f.name];
  return out;
}

function encode(item) {
  const clazz = REGISTRY[item.msgid];
  if (!clazz) throw new Error(`encode: message id ${item.msgid} is not in the registry`);
  const msg = new clazz();
  for (const f of clazz.FIELDS) {
    if (!(f.source in item.fields)) throw new Error(`encode: ${clazz.MSG_NAME}.${f.source} missing`);
    msg[f.name] = item.fields[f.source];
  }
  const protocol = new MavLinkProtocolV2(item.sysid, item.compid);
  return protocol.serialize(msg, item.seq).toString('hex');
}

function decodeAll(hexFrames) {
  return new Promise((resolve, reject) => {
    const splitter = new MavLinkPacketSplitter();
    const parser = splitter.pipe(new MavLinkPacketParser());
    const decoded = [];
    parser.on('data', packet => {
      const clazz = REGISTRY[packet.header.msgid];
      const entry = {
        msgid: packet.header.msgid,
        seq: packet.header.seq,
        sysid: packet.header.sysid,
        compid: packet.header.compid,
        incompat_flags: packet.header.incompatibilityFlags,
        payload_length: packet.header.payloadLength,
        crc: packet.crc,
        fields: clazz ? fieldsOf(packet.protocol.data(packet.payload, clazz), clazz) : null,
      };
      decoded.push(entry);
    });
    parser.on('end', () => resolve({ decoded, invalid: splitter.invalidPackages }));
    parser.on('error', reject);
    for (const hex of hexFrames) splitter.write(Buffer.from(hex, 'hex'));
    splitter.end();
  });
}

async function main() {
  const [inPath, outPath] = process.argv.slice(2);
  if (!inPath || !outPath) throw new Error('usage: node check.js IN.json OUT.json');
  const input = JSON.parse(fs.readFileSync(inPath, 'utf8'));
  const pkg = name => JSON.parse(fs.readFileSync(
      path.join(path.dirname(require.resolve(name)), '..', 'package.json'), 'utf8')).version;
  const { decoded, invalid } = await decodeAll(input.decode || []);
  const encoded = (input.encode || []).map(encode);
  const out = {
    versions: { 'node-mavlink': pkg('node-mavlink'), 'mavlink-mappings': pkg('mavlink-mappings') },
    decoded, invalid, encoded,
  };
  // BigInt never occurs in these messages (no 64-bit fields); fail loudly if it does.
  fs.writeFileSync(outPath, JSON.stringify(out));
}

main().catch(e => { console.error(`mavlink-check: ${e.stack || e}`); process.exit(1); });

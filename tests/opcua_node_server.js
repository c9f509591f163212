// A second, independent OPC UA server for the collector tests: node-opcua (npm, MIT), not asyncua.
//
// node tests/opcua_node_server.js TRACE.json PORT PKI_FOLDER
//
// Loads the OPC Foundation's nodesets shipped in node-opcua-nodesets (base, DI, IA, Machinery,
// ISA-95 job control, Machinery Jobs, Machine Tool, CNC), makes the instances from their types
// (Objects/CncInterface of CncInterfaceType with a Spindle of CncSpindleType and a Channel of
// CncChannelType; Objects/Machines/Lathe of MachineToolType) and a part counter in a namespace
// of its own (Objects/Lathe/PartCount: neither specification places one), listens on
// 127.0.0.1 only, prints "ready" and, on the line "play" on stdin, writes every sample of the
// trace with its own SourceTimestamp (1 ms apart): changed values only, the load every sample.
// TRACE.json: {"program": "O1001", "samples": [[part_count, execution, block, tool_number,
// spindle_load, spindle_speed_rpm, feed_rate_mm_min], ...]}. Ends when stdin closes.
"use strict";

const fs = require("fs");
const path = require("path");
const readline = require("readline");
const {
    OPCUAServer,
    OPCUACertificateManager,
    Variant,
    VariantArrayType,
    DataType,
    StatusCodes,
    SecurityPolicy,
    MessageSecurityMode,
} = require("node-opcua");
const { nodesets } = require("node-opcua-nodesets");

const CNC = "http://opcfoundation.org/UA/CNC";
const MACHINE_TOOL = "http://opcfoundation.org/UA/MachineTool/";
const MACHINERY = "http://opcfoundation.org/UA/Machinery/";
const BASE_MS = Date.UTC(2026, 10, 25);

function objectType(addressSpace, uri, name) {
    const found = addressSpace.findObjectType(name, addressSpace.getNamespaceIndex(uri));
    if (!found) throw new Error(`no ObjectType ${name} in ${uri}`);
    return found;
}

function child(node, uri, name) {
    const index = node.addressSpace.getNamespaceIndex(uri);
    const found = node.getChildByName(name, index);
    if (!found) throw new Error(`no ${name} under ${node.browseName.toString()}`);
    return found;
}

function buildSpace(addressSpace) {
    const cnc = addressSpace.getNamespaceIndex(CNC);
    const own = addressSpace.registerNamespace("urn:rcb-supervisor:test-lathe-node-opcua");
    const objects = addressSpace.rootFolder.objects;
    const iface = objectType(addressSpace, CNC, "CncInterfaceType").instantiate({
        browseName: { name: "CncInterface", namespaceIndex: cnc },
        organizedBy: objects,
    });
    const spindle = objectType(addressSpace, CNC, "CncSpindleType").instantiate({
        browseName: { name: "Spindle", namespaceIndex: own.index },
        componentOf: child(iface, CNC, "CncSpindleList"),
    });
    const channel = objectType(addressSpace, CNC, "CncChannelType").instantiate({
        browseName: { name: "Channel", namespaceIndex: own.index },
        componentOf: child(iface, CNC, "CncChannelList"),
    });
    const machines = objects.getFolderElementByName(
        "Machines",
        addressSpace.getNamespaceIndex(MACHINERY),
    );
    const lathe = objectType(addressSpace, MACHINE_TOOL, "MachineToolType").instantiate({
        browseName: { name: "Lathe", namespaceIndex: own.index },
        organizedBy: machines,
    });
    const active = child(child(lathe, MACHINE_TOOL, "Production"), MACHINE_TOOL, "ActiveProgram");
    const counter = own.addObject({ browseName: "Lathe", organizedBy: objects });
    const partCount = own.addVariable({
        componentOf: counter,
        browseName: "PartCount",
        dataType: "UInt32",
        value: { dataType: DataType.UInt32, value: 0 },
    });
    return {
        execution: [child(channel, CNC, "ActStatus"), DataType.Int32],
        program: [child(active, MACHINE_TOOL, "Name"), DataType.String],
        part_count: [partCount, DataType.UInt32],
        tool_number: [child(channel, CNC, "ToolId"), DataType.UInt32],
        block: [child(channel, CNC, "ActProgramBlock"), DataType.String, true],
        spindle_speed_rpm: [child(spindle, CNC, "ActSpeed"), DataType.Double],
        feed_rate_mm_min: [child(channel, CNC, "ActFeedrate"), DataType.Double],
        spindle_load: [child(spindle, CNC, "ActLoad"), DataType.Double],
    };
}

function values(program, sample) {
    const [partCount, execution, block, tool, load, rpm, feed] = sample;
    return {
        execution: execution === "ACTIVE" ? 2 : 0, // CncChannelStatus: 0 Reset, 2 Active
        program,
        part_count: partCount,
        tool_number: tool,
        block: `N${block} G01`,
        spindle_speed_rpm: rpm,
        feed_rate_mm_min: feed,
        spindle_load: load,
    };
}

function write(nodes, program, before, sample, i) {
    const stamp = new Date(BASE_MS + i);
    const now = values(program, sample);
    const old = before === null ? null : values(program, before);
    for (const [item, value] of Object.entries(now)) {
        if (old !== null && item !== "spindle_load" && old[item] === value) continue;
        const [node, dataType, array] = nodes[item];
        const variant = array
            ? new Variant({ dataType, arrayType: VariantArrayType.Array, value: [value, "", ""] })
            : new Variant({ dataType, value });
        node.setValueFromSource(variant, StatusCodes.Good, stamp);
    }
}

async function main() {
    const [tracePath, port, pki] = process.argv.slice(2);
    const trace = JSON.parse(fs.readFileSync(tracePath, "utf8"));
    const serverCertificateManager = new OPCUACertificateManager({
        rootFolder: path.join(pki, "server"),
        automaticallyAcceptUnknownCertificate: true,
    });
    const server = new OPCUAServer({
        port: Number(port),
        host: "127.0.0.1",
        hostname: "127.0.0.1",
        resourcePath: "/rcb",
        nodeset_filename: [
            nodesets.standard,
            nodesets.di,
            nodesets.ia,
            nodesets.machinery,
            nodesets.isa95JobControl,
            nodesets.machineryJobs,
            nodesets.machineTool,
            nodesets.cnc,
        ],
        securityPolicies: [SecurityPolicy.None],
        securityModes: [MessageSecurityMode.None],
        allowAnonymous: true,
        serverCertificateManager,
        // every change reported (the collector's sampling interval 0 is answered with 0): by
        // default node-opcua coalesces the changes of 100 ms into the last one, and a pass's
        // peak between two reports would be lost
        serverCapabilities: { minSupportedSampleRate: 0 },
    });
    await server.initialize();
    const nodes = buildSpace(server.engine.addressSpace);
    const samples = trace.samples;
    write(nodes, trace.program, null, samples[0], 0);
    await server.start();
    process.stdout.write(`ready ${server.getEndpointUrl()}\n`);

    const input = readline.createInterface({ input: process.stdin });
    let playing = false;
    for await (const line of input) {
        if (line.trim() !== "play" || playing) continue;
        playing = true;
        for (let i = 1; i < samples.length; i++) {
            write(nodes, trace.program, samples[i - 1], samples[i], i);
            if (i % 20 === 0) await new Promise((done) => setTimeout(done, 4));
        }
        process.stdout.write("played\n");
    }
    await server.shutdown(0);
    process.exit(0);
}

main().catch((error) => {
    process.stderr.write(`opcua_node_server: ${error.stack || error}\n`);
    process.exit(1);
});

// cornet-ns3: one 802.11 network simulated by ns-3 3.37 in lockstep with CORNET's physics.
// In the adhoc topology, ns-3's OLSR or AODV may route over several hops (init "routing").
//
//     cornet-ns3 ENDPOINT        (e.g. ipc:///tmp/cornet-xyz/ns3.sock; the bridge binds it)
//
// Rules and invariants (the protocol is documented in README.md beside this file):
// - One REP socket, connected to ENDPOINT. Every request gets exactly one reply; a bad request
//   gets {"op": "error"} and the program keeps serving. `close` replies and exits 0.
// - Protocol time ("now_s", "until_s", "send_time_s", "time_s") is the physics clock. ns-3's
//   own clock runs ahead of it by the warm-up: ns3_time = protocol_time + warmup.
// - ns-3 only moves inside `step`, up to exactly `until_s` (or, with `stop_at_delivery`, to the
//   first delivery before it: the reply's `now_s`); packets are injected at their
//   `send_time_s` (clamped to now if in the past) as UDP datagrams of `size` bytes between the
//   nodes' IP addresses. Their first 8 bytes carry the packet id; the real bytes stay in Python.
// - Every injected packet is eventually reported exactly once: delivered (with its time) or
//   dropped (with a reason: "loss" for a MAC retry-limit drop or no delivery within
//   `drop_after_s`, "queue" for a MAC queue drop).
// - Seeded: same init + same steps -> same replies, byte for byte.
// - A step with stop_at_delivery ends at the first delivery to a node that is not "passive"
//   (a passive node's deliveries cannot make anything send before the step's end).
#include <limits>
#include "json.h"
#include "lte.h"

#include "ns3/core-module.h"
#include "ns3/csma-module.h"
#include "ns3/internet-module.h"
#include "ns3/aodv-module.h"
#include "ns3/mobility-module.h"
#include "ns3/network-module.h"
#include "ns3/olsr-module.h"
#include "ns3/wifi-module.h"

#include <cstdint>
#include <cstring>
#include <iostream>
#include <set>
#include <sstream>
#include <unordered_map>
#include <zmq.hpp>

using namespace ns3;

namespace cornet
{

constexpr int kProtocolVersion = 1;
constexpr uint16_t kPort = 9000;
constexpr uint32_t kIdBytes = 8;

Time ToTime(double seconds)
{
    return NanoSeconds(static_cast<int64_t>(std::llround(seconds * 1e9)));
}

struct SimNode
{
    std::string name;
    std::string kind; // "vehicle", "ground", "ap" or "enb"
    Ptr<Node> node;
    Ptr<ConstantPositionMobilityModel> mobility;
    Ipv4Address address;
    Ptr<Socket> socket;
    Ptr<WifiNetDevice> wifi; // null for wired-only nodes
    bool passive = false;    // a delivery to it never ends a stop_at_delivery step
};

struct Pending
{
    double send_time_s;
};

class Engine
{
  public:
    std::string Handle(const Json& request);

  private:
    bool m_ready = false;
    Time m_offset;           // ns-3 time at protocol time 0 (the warm-up)
    double m_dropAfterS = 1.0;
    std::vector<SimNode> m_nodes;
    std::map<std::string, size_t> m_byName;
    std::unordered_map<uint64_t, Pending> m_pending;   // packet id -> what we know
    std::unordered_map<uint64_t, uint64_t> m_uidToId;  // ns-3 packet uid -> packet id
    std::set<uint32_t> m_passive;                      // ns-3 node ids of passive nodes
    std::ostringstream m_delivered; // JSON items of this step
    std::ostringstream m_dropped;
    bool m_firstDelivered = true;
    bool m_stopAtDelivery = false; // this step ends at its first delivery
    bool m_firstDropped = true;
    bool m_lte = false; // the "lte" topology (lte.h) instead of Wi-Fi
    LteNetwork m_lteNetwork;

    std::string Init(const Json& request);
    std::string Step(const Json& request);
    double Now() const
    {
        return (Simulator::Now() - m_offset).GetSeconds();
    }
    const SimNode& NodeNamed(const std::string& name) const;
    void SetPosition(SimNode& n, const Json& ned);
    void Send(uint64_t id, size_t src, size_t dst, uint32_t size);
    void Receive(Ptr<Socket> socket);
    void MacDrop(WifiMacDropReason reason, Ptr<const WifiMpdu> mpdu);
    void Report(uint64_t id, const char* reason);
};

const SimNode& Engine::NodeNamed(const std::string& name) const
{
    auto it = m_byName.find(name);
    if (it == m_byName.end())
        throw std::runtime_error("unknown node '" + name + "'");
    return m_nodes[it->second];
}

void Engine::SetPosition(SimNode& n, const Json& ned)
{
    if (ned.type != Json::Array || ned.a.size() != 3)
        throw std::runtime_error("position of '" + n.name + "' must be [n, e, d]");
    // NED metres -> ns-3 x = north, y = east, z = up.
    n.mobility->SetPosition(Vector(ned.a[0].n, ned.a[1].n, -ned.a[2].n));
}

void Engine::Report(uint64_t id, const char* reason)
{
    if (m_pending.erase(id) == 0)
        return; // already reported (e.g. a retry-limit drop of a duplicate)
    m_dropped << (m_firstDropped ? "" : ",") << "{\"id\":" << id << ",\"reason\":\"" << reason
              << "\"}";
    m_firstDropped = false;
}

void Engine::Send(uint64_t id, size_t src, size_t dst, uint32_t size)
{
    std::vector<uint8_t> payload(std::max(size, kIdBytes), 0);
    std::memcpy(payload.data(), &id, kIdBytes); // little endian on every platform we build on
    Ptr<Packet> packet = Create<Packet>(payload.data(), payload.size());
    m_uidToId[packet->GetUid()] = id;
    m_nodes[src].socket->SendTo(packet, 0, InetSocketAddress(m_nodes[dst].address, kPort));
}

void Engine::Receive(Ptr<Socket> socket)
{
    Ptr<Packet> packet;
    Address from;
    while ((packet = socket->RecvFrom(from)))
    {
        if (packet->GetSize() < kIdBytes)
            continue;
        uint64_t id = 0;
        packet->CopyData(reinterpret_cast<uint8_t*>(&id), kIdBytes);
        if (m_pending.erase(id) == 0)
            continue; // a duplicate, or already declared lost
        m_delivered << (m_firstDelivered ? "" : ",") << "{\"id\":" << id
                    << ",\"time_s\":" << JsonTime(Now()) << "}";
        m_firstDelivered = false;
        if (m_stopAtDelivery && !m_passive.count(socket->GetNode()->GetId()))
            Simulator::Stop(); // after this event: the caller learns the delivery at its time
    }
}

void Engine::MacDrop(WifiMacDropReason reason, Ptr<const WifiMpdu> mpdu)
{
    auto it = m_uidToId.find(mpdu->GetPacket()->GetUid());
    if (it == m_uidToId.end())
        return; // not one of ours (management frames, ARP)
    Report(it->second, reason == WIFI_MAC_DROP_REACHED_RETRY_LIMIT ? "loss" : "queue");
}

// An optional sub-object of a request: absent means every key takes its default.
Json Section(const Json& r, const std::string& key)
{
    Json section = r[key];
    if (section.type == Json::Null)
        section.type = Json::Object;
    if (section.type != Json::Object)
        throw std::runtime_error("'" + key + "' must be an object");
    return section;
}

WifiStandard StandardNamed(const std::string& name)
{
    static const std::map<std::string, WifiStandard> standards = {
        {"80211a", WIFI_STANDARD_80211a},
        {"80211b", WIFI_STANDARD_80211b},
        {"80211g", WIFI_STANDARD_80211g},
        {"80211n", WIFI_STANDARD_80211n},
        {"80211ac", WIFI_STANDARD_80211ac},
        {"80211ax", WIFI_STANDARD_80211ax},
    };
    auto it = standards.find(name);
    if (it == standards.end())
        throw std::runtime_error("unknown wifi standard '" + name +
                                 "' (known: 80211a, 80211b, 80211g, 80211n, 80211ac, 80211ax)");
    return it->second;
}

std::string Engine::Init(const Json& r)
{
    if (m_ready)
        throw std::runtime_error("init twice");
    RngSeedManager::SetSeed(static_cast<uint32_t>(std::max(1.0, r.Num("seed", 1))));
    RngSeedManager::SetRun(static_cast<uint64_t>(r.Num("run", 1)));
    m_dropAfterS = r.Num("drop_after_s", 1.0);
    const std::string topology = r.Str("topology", "adhoc");
    if (topology != "adhoc" && topology != "ap" && topology != "lte")
        throw std::runtime_error("topology must be 'adhoc', 'ap' or 'lte', not '" + topology +
                                 "'");
    m_lte = topology == "lte";
    // Multi-hop in the adhoc topology: ns-3's OLSR or AODV on every radio node ("none": one hop).
    const std::string routing = r.Str("routing", "none");
    if (routing != "none" && routing != "olsr" && routing != "aodv")
        throw std::runtime_error("routing must be 'none', 'olsr' or 'aodv', not '" + routing + "'");
    if (routing != "none" && topology != "adhoc")
        throw std::runtime_error("routing '" + routing + "' needs the adhoc topology");
    const Json wifiCfg = Section(r, "wifi");
    const Json prop = Section(r, "propagation");
    const Json wired = Section(r, "wired");

    const Json& nodes = r["nodes"];
    if (nodes.type != Json::Array || nodes.a.empty())
        throw std::runtime_error("'nodes' must be a non-empty list");
    for (const Json& n : nodes.a)
    {
        SimNode s;
        s.name = n.Str("name", "");
        s.kind = n.Str("kind", "");
        if (s.name.empty() || m_byName.count(s.name))
            throw std::runtime_error("node names must be unique and non-empty");
        if (s.kind != "vehicle" && s.kind != "ground" && s.kind != "ap" && s.kind != "enb")
            throw std::runtime_error("node '" + s.name +
                                     "': kind must be vehicle, ground, ap or enb");
        if ((s.kind == "enb" && !m_lte) || (s.kind == "ap" && m_lte))
            throw std::runtime_error("node '" + s.name + "': kind '" + s.kind +
                                     "' in topology '" + topology + "'");
        const Json& passive = n["passive"];
        if (passive.type != Json::Null && passive.type != Json::Bool)
            throw std::runtime_error("node '" + s.name + "': passive must be true or false");
        s.passive = passive.type == Json::Bool && passive.b;
        s.node = CreateObject<Node>();
        if (s.passive)
            m_passive.insert(s.node->GetId());
        s.mobility = CreateObject<ConstantPositionMobilityModel>();
        s.node->AggregateObject(s.mobility);
        m_byName[s.name] = m_nodes.size();
        m_nodes.push_back(s);
        if (n["position"].type != Json::Null)
            SetPosition(m_nodes.back(), n["position"]);
    }

    // The radio: YANS channel, log-distance loss (optionally Nakagami fading on top).
    YansWifiChannelHelper channel;
    channel.SetPropagationDelay("ns3::ConstantSpeedPropagationDelayModel");
    channel.AddPropagationLoss("ns3::LogDistancePropagationLossModel",
                               "Exponent", DoubleValue(prop.Num("exponent", 3.0)),
                               "ReferenceDistance", DoubleValue(prop.Num("reference_distance_m", 1.0)),
                               "ReferenceLoss", DoubleValue(prop.Num("reference_loss_db", 40.05)));
    if (prop.Num("nakagami_m", 0.0) > 0.0)
    {
        double m = prop.Num("nakagami_m", 0.0);
        channel.AddPropagationLoss("ns3::NakagamiPropagationLossModel", "m0", DoubleValue(m),
                                   "m1", DoubleValue(m), "m2", DoubleValue(m));
    }
    YansWifiPhyHelper phy;
    phy.SetChannel(channel.Create());
    const double txPower = wifiCfg.Num("tx_power_dbm", 16.0206);
    phy.Set("TxPowerStart", DoubleValue(txPower));
    phy.Set("TxPowerEnd", DoubleValue(txPower));
    phy.Set("RxSensitivity", DoubleValue(wifiCfg.Num("rx_sensitivity_dbm", -101.0)));
    phy.Set("CcaEdThreshold", DoubleValue(wifiCfg.Num("cca_ed_threshold_dbm", -62.0)));
    // ns-3's default preamble detection drops every frame weaker than -82 dBm: with exponent 3
    // and 40 dB reference loss that is a hard range of ~85 m. Configurable on purpose.
    phy.SetPreambleDetectionModel(
        "ns3::ThresholdPreambleDetectionModel",
        "MinimumRssi", DoubleValue(wifiCfg.Num("preamble_detection_min_rssi_dbm", -82.0)),
        "Threshold", DoubleValue(wifiCfg.Num("preamble_detection_snr_db", 4.0)));

    WifiHelper wifi;
    wifi.SetStandard(StandardNamed(wifiCfg.Str("standard", "80211g")));
    const std::string manager = wifiCfg.Str("rate_manager", "ns3::ConstantRateWifiManager");
    if (manager == "ns3::ConstantRateWifiManager")
    {
        const std::string data = wifiCfg.Str("data_mode", "ErpOfdmRate6Mbps");
        wifi.SetRemoteStationManager(manager, "DataMode", StringValue(data), "ControlMode",
                                     StringValue(wifiCfg.Str("control_mode", data)));
    }
    else
        wifi.SetRemoteStationManager(manager);

    NodeContainer radios, stas, aps, wiredNodes;
    for (SimNode& s : m_nodes)
    {
        if (topology == "adhoc")
        {
            if (s.kind == "ap")
                throw std::runtime_error("an 'ap' node in an adhoc topology");
            radios.Add(s.node);
        }
        else if (s.kind == "vehicle")
            stas.Add(s.node);
        else if (s.kind == "ap")
            aps.Add(s.node);
        else
            wiredNodes.Add(s.node);
    }
    InternetStackHelper internet;
    OlsrHelper olsr;
    AodvHelper aodv;
    if (routing != "none")
    {
        // Static routing first (local delivery), then the ad-hoc protocol.
        Ipv4StaticRoutingHelper staticRouting;
        Ipv4ListRoutingHelper list;
        list.Add(staticRouting, 0);
        if (routing == "olsr")
            list.Add(olsr, 10);
        else
            list.Add(aodv, 10);
        internet.SetRoutingHelper(list);
    }
    for (SimNode& s : m_nodes)
        if (s.kind != "enb") // the LTE EPC helper gives each eNB its stack
            internet.Install(s.node);
    Ipv4AddressHelper wifiNet("10.1.0.0", "255.255.0.0");
    Ipv4AddressHelper wiredNet("10.2.0.0", "255.255.0.0");
    WifiMacHelper mac;
    auto assign = [this](const NetDeviceContainer& devs, const Ipv4InterfaceContainer& ifs) {
        for (uint32_t i = 0; i < devs.GetN(); ++i)
        {
            SimNode& s = m_nodes[m_byName.at(Names::FindName(devs.Get(i)->GetNode()))];
            s.address = ifs.GetAddress(i);
            if (auto w = DynamicCast<WifiNetDevice>(devs.Get(i)))
                s.wifi = w;
        }
    };
    for (SimNode& s : m_nodes)
        Names::Add(s.name, s.node);

    if (topology == "adhoc")
    {
        mac.SetType("ns3::AdhocWifiMac");
        NetDeviceContainer devs = wifi.Install(phy, mac, radios);
        assign(devs, wifiNet.Assign(devs));
    }
    else if (m_lte)
    {
        std::vector<LteMember> members;
        for (const SimNode& s : m_nodes)
            members.push_back(LteMember{s.name, s.kind, s.node, Ipv4Address()});
        m_lteNetwork.Build(members, Section(r, "lte"), prop, wired);
        for (size_t i = 0; i < members.size(); ++i)
            m_nodes[i].address = members[i].address;
    }
    else
    {
        if (aps.GetN() != 1)
            throw std::runtime_error("an 'ap' topology needs exactly one node of kind 'ap'");
        Ssid ssid("cornet");
        // A station that misses beacons at the edge of range would drop its association and
        // re-associate; ns-3 3.37 then aborts ("No BSSID set for the link...") or crashes. A
        // vehicle stays associated (its losses show as MAC retries and drops instead).
        mac.SetType("ns3::StaWifiMac", "Ssid", SsidValue(ssid),
                    "MaxMissedBeacons", UintegerValue(std::numeric_limits<uint32_t>::max()));
        NetDeviceContainer staDevs = wifi.Install(phy, mac, stas);
        mac.SetType("ns3::ApWifiMac", "Ssid", SsidValue(ssid));
        NetDeviceContainer apDevs = wifi.Install(phy, mac, aps);
        NetDeviceContainer radioDevs(apDevs, staDevs);
        Ipv4InterfaceContainer radioIfs = wifiNet.Assign(radioDevs);
        // The AP answers on its radio address; ground nodes keep their wired one, and a vehicle
        // reaches a ground node through the AP (global routing below).
        SimNode& ap = m_nodes[m_byName.at(Names::FindName(aps.Get(0)))];
        ap.wifi = DynamicCast<WifiNetDevice>(apDevs.Get(0));
        ap.address = radioIfs.GetAddress(0);
        for (uint32_t i = 0; i < staDevs.GetN(); ++i)
        {
            SimNode& s = m_nodes[m_byName.at(Names::FindName(staDevs.Get(i)->GetNode()))];
            s.address = radioIfs.GetAddress(i + 1);
            s.wifi = DynamicCast<WifiNetDevice>(staDevs.Get(i));
        }
        if (wiredNodes.GetN() > 0)
        {
            CsmaHelper csma;
            csma.SetChannelAttribute("DataRate", StringValue(wired.Str("data_rate", "100Mbps")));
            csma.SetChannelAttribute("Delay", TimeValue(ToTime(wired.Num("delay_s", 0.0001))));
            NodeContainer lan(aps, wiredNodes);
            NetDeviceContainer lanDevs = csma.Install(lan);
            Ipv4InterfaceContainer lanIfs = wiredNet.Assign(lanDevs);
            for (uint32_t i = 1; i < lanDevs.GetN(); ++i)
                m_nodes[m_byName.at(Names::FindName(lanDevs.Get(i)->GetNode()))].address =
                    lanIfs.GetAddress(i);
        }
        Ipv4GlobalRoutingHelper::PopulateRoutingTables();
    }
    // ARP pre-filled for every interface: no packet waits for (or is lost to) ARP.
    NeighborCacheHelper().PopulateNeighborCache();

    for (SimNode& s : m_nodes)
    {
        s.socket = Socket::CreateSocket(s.node, UdpSocketFactory::GetTypeId());
        s.socket->Bind(InetSocketAddress(Ipv4Address::GetAny(), kPort));
        s.socket->SetRecvCallback(MakeCallback(&Engine::Receive, this));
        if (s.wifi)
            s.wifi->GetMac()->TraceConnectWithoutContext("DroppedMpdu",
                                                         MakeCallback(&Engine::MacDrop, this));
    }

    // Warm-up: beacons, scanning and association (~130 ms in AP mode) happen before protocol
    // time 0, so no packet of the run is lost to association.
    const double warmup = r.Num("warmup_s", 1.0);
    Simulator::Stop(ToTime(warmup));
    Simulator::Run();
    m_offset = Simulator::Now();
    m_ready = true;
    if (m_lte)
        m_lteNetwork.Start(m_offset);

    std::ostringstream out;
    out << "{\"v\":" << kProtocolVersion << ",\"op\":\"ready\",\"now_s\":" << JsonTime(Now())
        << ",\"warmup_s\":" << JsonTime(warmup) << ",\"addresses\":{";
    bool first = true;
    for (const SimNode& s : m_nodes)
    {
        std::ostringstream ip;
        ip << s.address;
        out << (first ? "" : ",") << JsonQuote(s.name) << ":" << JsonQuote(ip.str());
        first = false;
    }
    out << "},\"unassociated\":[";
    first = true;
    for (const SimNode& s : m_nodes)
    {
        if (topology != "ap" || s.kind != "vehicle")
            continue;
        auto sta = DynamicCast<StaWifiMac>(s.wifi->GetMac());
        if (!sta->IsAssociated())
        {
            out << (first ? "" : ",") << JsonQuote(s.name);
            first = false;
        }
    }
    if (m_lte)
        for (const std::string& name : m_lteNetwork.Unattached())
        {
            out << (first ? "" : ",") << JsonQuote(name);
            first = false;
        }
    out << "]";
    if (m_lte)
        out << ",\"cells\":" << m_lteNetwork.CellsJson() << ",\"serving\":"
            << m_lteNetwork.ServingJson();
    out << "}";
    return out.str();
}

std::string Engine::Step(const Json& r)
{
    if (!m_ready)
        throw std::runtime_error("step before init");
    const double until = r.Num("until_s", NAN);
    if (!(until >= Now()))
        throw std::runtime_error("until_s must be a number >= now_s");
    const Json& positions = r["positions"];
    if (positions.type == Json::Object)
        for (const auto& [name, ned] : positions.o)
            SetPosition(m_nodes[m_byName.at(NodeNamed(name).name)], ned);
    const Json& stopFlag = r["stop_at_delivery"];
    if (stopFlag.type != Json::Null && stopFlag.type != Json::Bool)
        throw std::runtime_error("'stop_at_delivery' must be true or false");
    const Json& packets = r["packets"];
    if (packets.type != Json::Null && packets.type != Json::Array)
        throw std::runtime_error("'packets' must be a list");
    // Validate the whole batch before scheduling any of it: a bad request changes nothing.
    struct Injection
    {
        uint64_t id;
        size_t src, dst;
        uint32_t size;
        double at;
    };
    std::vector<Injection> batch;
    for (const Json& p : packets.a)
    {
        Injection in;
        in.id = static_cast<uint64_t>(p.Num("id", -1));
        in.src = m_byName.at(NodeNamed(p.Str("src", "")).name);
        in.dst = m_byName.at(NodeNamed(p.Str("dst", "")).name);
        in.size = static_cast<uint32_t>(p.Num("size", 0));
        in.at = std::max(p.Num("send_time_s", Now()), Now());
        if (in.src == in.dst)
            throw std::runtime_error("packet " + std::to_string(in.id) + ": src == dst");
        if (m_pending.count(in.id))
            throw std::runtime_error("packet id " + std::to_string(in.id) + " reused");
        batch.push_back(in);
    }
    m_delivered.str("");
    m_dropped.str("");
    m_firstDelivered = m_firstDropped = true;
    m_stopAtDelivery = stopFlag.type == Json::Bool && stopFlag.b;
    for (const Injection& in : batch)
    {
        m_pending[in.id] = Pending{in.at};
        Simulator::Schedule(ToTime(in.at) + m_offset - Simulator::Now(), &Engine::Send, this,
                            in.id, in.src, in.dst, in.size);
    }
    // The end of the step as an event of its own, cancelled when a delivery stopped it first
    // (Simulator::Stop(delay) could not be taken back: it would end the next step early).
    EventId end = Simulator::Schedule(ToTime(until) + m_offset - Simulator::Now(),
                                      static_cast<void (*)()>(&Simulator::Stop));
    Simulator::Run();
    Simulator::Cancel(end);
    const double reached = Now();

    // Packets that never arrived: lost (no route, out of range with no MAC drop reported...).
    std::vector<uint64_t> expired;
    for (const auto& [id, p] : m_pending)
        if (p.send_time_s + m_dropAfterS <= reached)
            expired.push_back(id);
    std::sort(expired.begin(), expired.end()); // unordered_map order is not a contract
    for (uint64_t id : expired)
        Report(id, "loss");
    if (m_uidToId.size() > 4 * m_pending.size() + 1024)
    {
        // Forget uids of packets already reported so the map does not grow forever.
        for (auto it = m_uidToId.begin(); it != m_uidToId.end();)
            it = m_pending.count(it->second) ? std::next(it) : m_uidToId.erase(it);
    }

    std::ostringstream out;
    out << "{\"v\":" << kProtocolVersion << ",\"op\":\"stepped\",\"now_s\":" << JsonTime(Now())
        << ",\"delivered\":[" << m_delivered.str() << "],\"dropped\":[" << m_dropped.str()
        << "],\"in_flight\":" << m_pending.size();
    if (m_lte)
        out << ",\"events\":[" << m_lteNetwork.TakeEventsJson() << "]";
    out << "}";
    return out.str();
}

std::string Engine::Handle(const Json& request)
{
    if (request.type != Json::Object)
        throw std::runtime_error("a request must be a JSON object");
    const int version = static_cast<int>(request.Num("v", -1));
    if (version != kProtocolVersion)
        throw std::runtime_error("protocol version " + std::to_string(version) +
                                 " not supported (this engine speaks " +
                                 std::to_string(kProtocolVersion) + ")");
    const std::string op = request.Str("op", "");
    if (op == "init")
        return Init(request);
    if (op == "step")
        return Step(request);
    if (op == "close")
        return "{\"v\":1,\"op\":\"closed\"}";
    throw std::runtime_error("unknown op '" + op + "'");
}

} // namespace cornet

int main(int argc, char** argv)
{
    if (argc != 2)
    {
        std::cerr << "usage: cornet-ns3 ENDPOINT   (e.g. ipc:///tmp/x/ns3.sock)\n";
        return 2;
    }
    zmq::context_t context(1);
    zmq::socket_t socket(context, zmq::socket_type::rep);
    socket.set(zmq::sockopt::linger, 0);
    socket.connect(argv[1]);
    cornet::Engine engine;
    while (true)
    {
        zmq::message_t message;
        if (!socket.recv(message, zmq::recv_flags::none))
            continue;
        std::string text = message.to_string();
        std::string reply;
        bool closing = false;
        try
        {
            cornet::Json request = cornet::JsonParser(text).Parse();
            reply = engine.Handle(request);
            closing = request.Str("op", "") == "close";
        }
        catch (const std::exception& e)
        {
            reply = std::string("{\"v\":1,\"op\":\"error\",\"error\":") +
                    cornet::JsonQuote(e.what()) + "}";
        }
        socket.send(zmq::buffer(reply), zmq::send_flags::none);
        if (closing)
            break;
    }
    ns3::Simulator::Destroy();
    return 0;
}

// The "lte" topology of cornet-ns3 (rules in lte.h; keys and defaults in README.md).
#include "lte.h"

#include "ns3/core-module.h"
#include "ns3/csma-module.h"
#include "ns3/point-to-point-module.h"

#include <algorithm>
#include <cmath>
#include <set>

using namespace ns3;

namespace cornet
{

namespace
{

// The keys of the `lte` section (README.md, "lte" topology).
const std::set<std::string> kLteKeys = {
    "enb_tx_power_dbm", "ue_tx_power_dbm", "bandwidth_rb", "earfcn", "rlc_mode",
    "handover_algorithm", "hysteresis_db", "time_to_trigger_s", "serving_cell_threshold",
    "neighbour_cell_offset", "s1u_delay_s", "x2_delay_s", "ideal_rrc"};
const std::set<std::string> kPropagationKeys = {"exponent", "reference_distance_m",
                                                "reference_loss_db", "nakagami_m"};
const char* const kA3 = "ns3::A3RsrpHandoverAlgorithm";
const char* const kA2A4 = "ns3::A2A4RsrqHandoverAlgorithm";
const char* const kNoHandover = "ns3::NoOpHandoverAlgorithm";
// The SRS periodicities LTE allows (3GPP TS 36.213 table 8.2-1, ns-3's LteEnbRrc): an eNB
// serves fewer UEs than its periodicity in ms.
const std::vector<uint32_t> kSrsPeriodicities = {2, 5, 10, 20, 40, 80, 160, 320};
// FDD: the uplink EARFCN is the downlink's + 18000 (3GPP TS 36.101 table 5.7.3-1).
constexpr uint32_t kUlEarfcnOffset = 18000;

// A section's keys against the known ones: an unknown key is an error that names it.
void CheckKeys(const Json& section, const std::string& name, const std::set<std::string>& known)
{
    for (const auto& [key, value] : section.o)
    {
        if (!known.count(key))
        {
            std::string list;
            for (const std::string& k : known)
                list += (list.empty() ? "" : ", ") + k;
            throw std::runtime_error(name + "." + key + ": unknown key (known: " + list + ")");
        }
    }
}

// Reads one value, naming the section in the error.
double Num(const Json& section, const std::string& name, const std::string& key, double fallback)
{
    try
    {
        return section.Num(key, fallback);
    }
    catch (const std::runtime_error&)
    {
        throw std::runtime_error(name + "." + key + ": must be a number");
    }
}

std::string Str(const Json& section, const std::string& name, const std::string& key,
                const std::string& fallback)
{
    try
    {
        return section.Str(key, fallback);
    }
    catch (const std::runtime_error&)
    {
        throw std::runtime_error(name + "." + key + ": must be a string");
    }
}

Time Seconds9(double s)
{
    return NanoSeconds(static_cast<int64_t>(std::llround(s * 1e9)));
}

} // namespace

void LteNetwork::Build(std::vector<LteMember>& members, const Json& lte, const Json& prop,
                       const Json& wired)
{
    CheckKeys(lte, "lte", kLteKeys);
    CheckKeys(prop, "propagation", kPropagationKeys);
    if (Num(prop, "propagation", "nakagami_m", 0.0) != 0.0)
        throw std::runtime_error("propagation.nakagami_m: not supported by the lte topology "
                                 "(LTE's own fading models are not wired up)");
    const double enbPower = Num(lte, "lte", "enb_tx_power_dbm", 46.0);
    const double uePower = Num(lte, "lte", "ue_tx_power_dbm", 23.0);
    const double rb = Num(lte, "lte", "bandwidth_rb", 25.0);
    if (rb != 6 && rb != 15 && rb != 25 && rb != 50 && rb != 75 && rb != 100)
        throw std::runtime_error("lte.bandwidth_rb: must be 6, 15, 25, 50, 75 or 100 "
                                 "(1.4 to 20 MHz)");
    const double earfcn = Num(lte, "lte", "earfcn", 100.0);
    if (!(earfcn >= 0 && earfcn < kUlEarfcnOffset) || earfcn != std::floor(earfcn))
        throw std::runtime_error("lte.earfcn: must be a downlink FDD EARFCN, an integer "
                                 "0..17999");
    const std::string rlc = Str(lte, "lte", "rlc_mode", "um");
    if (rlc != "um" && rlc != "am")
        throw std::runtime_error("lte.rlc_mode: must be \"um\" or \"am\", not \"" + rlc + "\"");
    const std::string handover = Str(lte, "lte", "handover_algorithm", kA3);
    if (handover != kA3 && handover != kA2A4 && handover != kNoHandover)
        throw std::runtime_error("lte.handover_algorithm: must be " + std::string(kA3) + ", " +
                                 kA2A4 + " or " + kNoHandover + ", not \"" + handover + "\"");
    for (const char* key : {"hysteresis_db", "time_to_trigger_s"})
        if (lte.Has(key) && handover != kA3)
            throw std::runtime_error(std::string("lte.") + key + ": only for " + kA3);
    for (const char* key : {"serving_cell_threshold", "neighbour_cell_offset"})
        if (lte.Has(key) && handover != kA2A4)
            throw std::runtime_error(std::string("lte.") + key + ": only for " + kA2A4);
    const double s1uDelay = Num(lte, "lte", "s1u_delay_s", 0.001);
    const double x2Delay = Num(lte, "lte", "x2_delay_s", 0.001);
    if (!(s1uDelay >= 0) || !(x2Delay >= 0))
        throw std::runtime_error(std::string("lte.") +
                                 (s1uDelay >= 0 ? "x2_delay_s" : "s1u_delay_s") +
                                 ": must be >= 0");
    const Json& idealRrc = lte["ideal_rrc"];
    if (idealRrc.type != Json::Null && idealRrc.type != Json::Bool)
        throw std::runtime_error("lte.ideal_rrc: must be true or false");

    NodeContainer enbs, ues, hosts;
    for (const LteMember& m : members)
    {
        if (m.kind == "enb")
            enbs.Add(m.node);
        else if (m.kind == "vehicle")
            ues.Add(m.node);
        else if (m.kind == "ground")
            hosts.Add(m.node);
        else
            throw std::runtime_error("node '" + m.name + "': kind '" + m.kind +
                                     "' is not part of an lte topology (vehicle, enb, ground)");
    }
    if (enbs.GetN() == 0)
        throw std::runtime_error("an 'lte' topology needs at least one node of kind 'enb'");
    auto srs = std::find_if(kSrsPeriodicities.begin(), kSrsPeriodicities.end(),
                            [&](uint32_t p) { return p > std::max(ues.GetN(), 39u); });
    if (srs == kSrsPeriodicities.end())
        throw std::runtime_error("an 'lte' topology takes at most 319 vehicles (UEs per cell "
                                 "are limited by the largest SRS periodicity, 320 ms)");

    // Defaults for the objects the helpers create below.
    Config::SetDefault("ns3::LteEnbPhy::TxPower", DoubleValue(enbPower));
    Config::SetDefault("ns3::LteUePhy::TxPower", DoubleValue(uePower));
    Config::SetDefault("ns3::LteUePowerControl::Pcmax", DoubleValue(uePower));
    Config::SetDefault("ns3::LteEnbRrc::SrsPeriodicity", UintegerValue(*srs));
    Config::SetDefault("ns3::LteEnbRrc::EpsBearerToRlcMapping",
                       EnumValue(rlc == "am" ? LteEnbRrc::RLC_AM_ALWAYS
                                             : LteEnbRrc::RLC_UM_ALWAYS));

    m_epc = CreateObject<PointToPointEpcHelper>();
    m_epc->SetAttribute("S1uLinkDelay", TimeValue(Seconds9(s1uDelay)));
    m_epc->SetAttribute("X2LinkDelay", TimeValue(Seconds9(x2Delay)));
    m_lte = CreateObject<LteHelper>();
    m_lte->SetAttribute("UseIdealRrc", BooleanValue(idealRrc.type != Json::Bool || idealRrc.b));
    m_lte->SetEpcHelper(m_epc);
    m_lte->SetPathlossModelType(LogDistancePropagationLossModel::GetTypeId());
    m_lte->SetPathlossModelAttribute("Exponent",
                                     DoubleValue(Num(prop, "propagation", "exponent", 3.0)));
    m_lte->SetPathlossModelAttribute(
        "ReferenceDistance", DoubleValue(Num(prop, "propagation", "reference_distance_m", 1.0)));
    m_lte->SetPathlossModelAttribute(
        "ReferenceLoss", DoubleValue(Num(prop, "propagation", "reference_loss_db", 38.57)));
    m_lte->SetEnbDeviceAttribute("DlBandwidth", UintegerValue(static_cast<uint16_t>(rb)));
    m_lte->SetEnbDeviceAttribute("UlBandwidth", UintegerValue(static_cast<uint16_t>(rb)));
    m_lte->SetEnbDeviceAttribute("DlEarfcn", UintegerValue(static_cast<uint32_t>(earfcn)));
    m_lte->SetEnbDeviceAttribute("UlEarfcn",
                                 UintegerValue(static_cast<uint32_t>(earfcn) + kUlEarfcnOffset));
    m_lte->SetUeDeviceAttribute("DlEarfcn", UintegerValue(static_cast<uint32_t>(earfcn)));
    m_lte->SetHandoverAlgorithmType(handover);
    if (handover == kA3)
    {
        m_lte->SetHandoverAlgorithmAttribute(
            "Hysteresis", DoubleValue(Num(lte, "lte", "hysteresis_db", 3.0)));
        m_lte->SetHandoverAlgorithmAttribute(
            "TimeToTrigger", TimeValue(Seconds9(Num(lte, "lte", "time_to_trigger_s", 0.256))));
    }
    else if (handover == kA2A4)
    {
        const double threshold = Num(lte, "lte", "serving_cell_threshold", 30.0);
        const double offset = Num(lte, "lte", "neighbour_cell_offset", 1.0);
        if (!(threshold >= 0 && threshold <= 34) || !(offset >= 0 && offset <= 34))
            throw std::runtime_error("lte.serving_cell_threshold and "
                                     "lte.neighbour_cell_offset: RSRQ ranges 0..34");
        m_lte->SetHandoverAlgorithmAttribute("ServingCellThreshold",
                                             UintegerValue(static_cast<uint8_t>(threshold)));
        m_lte->SetHandoverAlgorithmAttribute("NeighbourCellOffset",
                                             UintegerValue(static_cast<uint8_t>(offset)));
    }

    // eNBs (the EPC helper gives each an internet stack and its S1 link), X2 between all.
    NetDeviceContainer enbDevs = m_lte->InstallEnbDevice(enbs);
    if (enbs.GetN() > 1)
        m_lte->AddX2Interface(enbs);

    // Remote hosts: one CSMA LAN with the PGW; they reach the UE network through it.
    std::map<Ptr<Node>, Ipv4Address> addressOf;
    if (hosts.GetN() > 0)
    {
        CsmaHelper csma;
        csma.SetChannelAttribute("DataRate", StringValue(wired.Str("data_rate", "100Mbps")));
        csma.SetChannelAttribute("Delay", TimeValue(Seconds9(wired.Num("delay_s", 0.0001))));
        NodeContainer lan(m_epc->GetPgwNode(), hosts);
        NetDeviceContainer lanDevs = csma.Install(lan);
        Ipv4AddressHelper lanNet("10.2.0.0", "255.255.0.0");
        Ipv4InterfaceContainer lanIfs = lanNet.Assign(lanDevs);
        Ipv4StaticRoutingHelper routing;
        for (uint32_t i = 1; i < lanDevs.GetN(); ++i)
        {
            Ptr<Ipv4> ipv4 = hosts.Get(i - 1)->GetObject<Ipv4>();
            routing.GetStaticRouting(ipv4)->AddNetworkRouteTo(
                Ipv4Address("7.0.0.0"), Ipv4Mask("255.0.0.0"), lanIfs.GetAddress(0),
                ipv4->GetInterfaceForDevice(lanDevs.Get(i)));
            addressOf[hosts.Get(i - 1)] = lanIfs.GetAddress(i);
        }
    }

    // UEs: addresses in 7.0.0.0/8, default route to the PGW, attached to the strongest cell.
    NetDeviceContainer ueDevs = m_lte->InstallUeDevice(ues);
    Ipv4InterfaceContainer ueIfs = m_epc->AssignUeIpv4Address(ueDevs);
    Ipv4StaticRoutingHelper routing;
    for (uint32_t i = 0; i < ues.GetN(); ++i)
    {
        routing.GetStaticRouting(ues.Get(i)->GetObject<Ipv4>())
            ->SetDefaultRoute(m_epc->GetUeDefaultGatewayAddress(), 1);
        addressOf[ues.Get(i)] = ueIfs.GetAddress(i);
    }
    m_lte->Attach(ueDevs);

    for (uint32_t i = 0; i < enbDevs.GetN(); ++i)
    {
        auto dev = DynamicCast<LteEnbNetDevice>(enbDevs.Get(i));
        for (LteMember& m : members)
            if (m.node == dev->GetNode())
            {
                m_cellName[dev->GetCellId()] = m.name;
                // An eNB has no address of its own in the user plane: its S1-U address.
                m.address = dev->GetNode()->GetObject<Ipv4>()->GetAddress(1, 0).GetLocal();
            }
    }
    for (uint32_t i = 0; i < ueDevs.GetN(); ++i)
    {
        auto dev = DynamicCast<LteUeNetDevice>(ueDevs.Get(i));
        Ptr<LteUeRrc> rrc = dev->GetRrc();
        for (const LteMember& m : members)
            if (m.node == dev->GetNode())
            {
                m_ueName[dev->GetImsi()] = m.name;
                m_ueRrc[m.name] = rrc;
            }
        rrc->TraceConnectWithoutContext(
            "HandoverStart",
            Callback<void, uint64_t, uint16_t, uint16_t, uint16_t>(
                [this](uint64_t imsi, uint16_t cell, uint16_t, uint16_t target) {
                    Event(imsi, "handover_start",
                          ",\"from\":" + JsonQuote(Cell(cell)) + ",\"to\":" +
                              JsonQuote(Cell(target)));
                }));
        const std::pair<const char*, const char*> endings[] = {
            {"HandoverEndOk", "handover_end"},
            {"HandoverEndError", "handover_error"},
            {"RadioLinkFailure", "radio_link_failure"},
            {"ConnectionEstablished", "connected"}};
        for (const auto& [trace, what] : endings)
        {
            std::string name = what;
            rrc->TraceConnectWithoutContext(
                trace, Callback<void, uint64_t, uint16_t, uint16_t>(
                           [this, name](uint64_t imsi, uint16_t cell, uint16_t) {
                               Event(imsi, name, ",\"cell\":" + JsonQuote(Cell(cell)));
                           }));
        }
    }
    for (LteMember& m : members)
        if (addressOf.count(m.node))
            m.address = addressOf[m.node];
}

void LteNetwork::Start(Time offset)
{
    m_offset = offset;
    m_started = true;
}

std::string LteNetwork::Cell(uint16_t cellId) const
{
    auto it = m_cellName.find(cellId);
    return it == m_cellName.end() ? "cell" + std::to_string(cellId) : it->second;
}

void LteNetwork::Event(uint64_t imsi, const std::string& what, const std::string& details)
{
    if (!m_started)
        return; // attach during the warm-up: the ready reply says where each UE is
    m_events << (m_firstEvent ? "" : ",") << "{\"time_s\":"
             << JsonTime((Simulator::Now() - m_offset).GetSeconds())
             << ",\"node\":" << JsonQuote(m_ueName.at(imsi)) << ",\"event\":" << JsonQuote(what)
             << details << "}";
    m_firstEvent = false;
}

std::string LteNetwork::TakeEventsJson()
{
    std::string out = m_events.str();
    m_events.str("");
    m_firstEvent = true;
    return out;
}

std::vector<std::string> LteNetwork::Unattached() const
{
    std::vector<std::string> out;
    for (const auto& [name, rrc] : m_ueRrc)
        if (rrc->GetState() != LteUeRrc::CONNECTED_NORMALLY)
            out.push_back(name);
    return out;
}

std::string LteNetwork::CellsJson() const
{
    std::ostringstream out;
    out << "{";
    bool first = true;
    for (const auto& [id, name] : m_cellName)
    {
        out << (first ? "" : ",") << JsonQuote(name) << ":" << id;
        first = false;
    }
    out << "}";
    return out.str();
}

std::string LteNetwork::ServingJson() const
{
    std::ostringstream out;
    out << "{";
    bool first = true;
    for (const auto& [name, rrc] : m_ueRrc)
    {
        const bool connected = rrc->GetState() >= LteUeRrc::CONNECTED_NORMALLY &&
                               rrc->GetState() < LteUeRrc::NUM_STATES;
        out << (first ? "" : ",") << JsonQuote(name) << ":"
            << (connected ? JsonQuote(Cell(rrc->GetCellId())) : "null");
        first = false;
    }
    out << "}";
    return out.str();
}

} // namespace cornet

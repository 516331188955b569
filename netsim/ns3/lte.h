// The "lte" topology of cornet-ns3: ns-3's LTE module (LENA) with an EPC.
//
// Rules and invariants:
// - Vehicles are UEs, nodes of kind "enb" are eNBs (one cell each), ground nodes (gcs, api*)
//   are remote hosts on a CSMA LAN behind the PGW. Every UE is attached at build time (initial
//   cell selection picks the strongest cell); the engine's warm-up covers attach and RRC
//   connection, and `Unattached` names UEs that were not connected after it.
// - All eNBs are X2 neighbours; the configured handover algorithm moves UEs between them.
// - Handovers and radio link failures are recorded as events with their ns-3 time; the engine
//   hands them out with each step reply (protocol time = ns-3 time - the warm-up).
// - A bad `lte` (or, for this topology, `propagation`) key throws std::runtime_error naming it.
#pragma once

#include "json.h"

#include "ns3/internet-module.h"
#include "ns3/lte-module.h"
#include "ns3/network-module.h"

#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace cornet
{

// One CORNET node as the LTE builder sees it.
struct LteMember
{
    std::string name;
    std::string kind; // "vehicle" (UE), "enb" or "ground" (a remote host behind the PGW)
    ns3::Ptr<ns3::Node> node;
    ns3::Ipv4Address address; // set by Build: where datagrams to this node go
};

class LteNetwork
{
  public:
    // Builds eNBs, EPC, UEs and remote hosts and attaches the UEs. The nodes already carry
    // their mobility; every node but the eNBs already has an internet stack.
    void Build(std::vector<LteMember>& members, const Json& lte, const Json& propagation,
               const Json& wired);
    // From now on events are recorded; `offset` is the ns-3 time of protocol time 0.
    void Start(ns3::Time offset);
    std::vector<std::string> Unattached() const;
    // {"enb1": 1, ...}: each eNB's cell id; {"v1": "enb1", ...}: each UE's serving cell.
    std::string CellsJson() const;
    std::string ServingJson() const;
    // The events since the last call, as JSON array items (without the brackets).
    std::string TakeEventsJson();

  private:
    bool m_started = false;
    ns3::Time m_offset;
    ns3::Ptr<ns3::LteHelper> m_lte;
    ns3::Ptr<ns3::PointToPointEpcHelper> m_epc;
    std::map<uint16_t, std::string> m_cellName;   // cell id -> eNB name
    std::map<uint64_t, std::string> m_ueName;     // IMSI -> vehicle name
    std::map<std::string, ns3::Ptr<ns3::LteUeRrc>> m_ueRrc;
    std::ostringstream m_events;
    bool m_firstEvent = true;

    std::string Cell(uint16_t cellId) const;
    void Event(uint64_t imsi, const std::string& what, const std::string& details);
};

} // namespace cornet

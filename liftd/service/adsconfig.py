"""[ads] of liftd.toml → the ADS server's and services' settings (composition helpers)."""

from __future__ import annotations

import ipaddress

from liftd.ads.server import ServerConfig
from liftd.ads.service import ServiceLimits
from liftd.ads.wire import AMS_SIZE, net_id_bytes
from liftd.settings.model import AdsSection


def server_config(ads: AdsSection) -> ServerConfig:
    return ServerConfig(
        host=ads.host,
        port=ads.port,
        net_ids=frozenset(net_id_bytes(n) for n in (ads.net_id, *ads.extra_net_ids)),
        ams_ports=frozenset(ads.ams_ports),
        max_connections=ads.max_connections,
        max_frame_bytes=ads.max_frame_bytes,
        write_queue_frames=ads.write_queue_frames,
        connection_budget_bytes=ads.connection_budget_bytes,
        budget_bytes=ads.budget_bytes,
        incomplete_frame_timeout_s=ads.incomplete_frame_timeout_s,
        first_frame_timeout_s=ads.first_frame_timeout_s,
        max_connections_per_ip=ads.max_connections_per_ip,
        system_service=ads.system_service,
        router_net_id=net_id_bytes(ads.net_id),
        allow_ips=tuple(ipaddress.ip_network(n, strict=False) for n in ads.allow_ips),
        allow_net_ids=frozenset(net_id_bytes(n) for n in ads.allow_net_ids),
        write_net_ids=frozenset(net_id_bytes(n) for n in ads.write_net_ids),
        reject=ads.reject,
    )


def service_limits(ads: AdsSection) -> ServiceLimits:
    return ServiceLimits(
        max_sum_subcommands=ads.max_sum_subcommands,
        max_handles=ads.max_handles_per_connection,
        max_notifications=ads.max_notifications_per_connection,
        min_notification_cycle_ns=ads.min_notification_cycle_us * 1000,
        max_notification_length=min(65536, ads.max_frame_bytes // 4),
        max_notification_payload=ads.max_frame_bytes - AMS_SIZE,
        max_reply_payload=ads.max_frame_bytes - AMS_SIZE,
    )
